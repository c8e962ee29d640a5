"""Moved to :mod:`tunnelsense.cli._common` (kept for the street commands' module)."""

from tunnelsense.cli._common import (  # noqa: F401
    add_model_arguments,
    add_output_arguments,
    check_draw_dir,
    input_files,
    load_cli_model,
    signing_key,
)
