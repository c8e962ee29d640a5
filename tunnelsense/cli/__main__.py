import sys

from tunnelsense.cli import main

sys.exit(main())
