"""``tunnelsense info``: what a tour, laser run or model file holds."""

from __future__ import annotations

import json

from tunnelsense.io import describe

_HELP = ("describe a tour (MOTChallenge folder, image folder, video), a laser run or "
         "a model file (.skops, .joblib)")


def _tree(facts, indent="  ") -> list[str]:
    """One fact per line; nested dicts (and lists of them) indented below their key."""
    lines = []
    for key, value in facts.items():
        if isinstance(value, dict) and value:
            lines += [f"{indent}{key}:", *_tree(value, indent + "  ")]
        elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            lines.append(f"{indent}{key}:")
            for item in value:
                sub = _tree(item, indent + "    ")
                lines += [indent + "  - " + sub[0].lstrip(), *sub[1:]]
        elif isinstance(value, list):
            lines.append(f"{indent}{key}: {', '.join(map(str, value))}")
        else:
            lines.append(f"{indent}{key}: {value}")
    return lines


def _headline(facts) -> str:
    if facts["kind"] == "model":
        return f"{facts['path']}: {facts['format']} model file, {facts['bytes']} bytes"
    if facts["kind"] == "tunnel":
        return (f"{facts['name']}: far-infrared tour, {facts['frames']} frames of "
                f"{facts['width']}x{facts['height']} px ({facts['dtype']}), "
                f"{facts['frame_rate']:g} fps")
    rate = facts["scan_rate"]
    return (f"{facts['name']}: laser run, {facts['scans']} scans of {facts['beams']} "
            f"beams" + (f", {rate:g} scans/s" if rate else "")
            + f", mount height {facts['mount_height']:g} m")


def _cmd_info(args) -> int:
    facts = describe(args.source)
    if args.json:
        print(json.dumps(facts, indent=2, sort_keys=True))
        return 0
    print(_headline(facts))
    shown = {"kind", "path", "format", "bytes", "name", "versions"}
    if facts["kind"] != "model":
        objects = facts.pop("objects")
        print("  objects: " + (", ".join(f"{n} {k}" for k, n in sorted(objects.items()))
                               or "none in the ground truth"))
    for name, version in sorted(facts.get("versions", {}).items()):
        print(f"  trained under {name} {version}")
    print("\n".join(_tree({k: v for k, v in facts.items() if k not in shown})))
    return 0


def register_top(sub) -> None:
    """Add the ``info`` command."""
    p = sub.add_parser("info", help=_HELP, description=_HELP[0].upper() + _HELP[1:]
                       + "; a model file is described by its model card (versions, "
                       "training summary), never loaded.")
    p.add_argument("source", help="MOTChallenge folder, image folder, video file, laser "
                   "run folder (scans.npz + gt.csv), ROS bag, or model file (.skops, "
                   ".joblib)")
    p.add_argument("--json", action="store_true",
                   help="print the facts as JSON (numbers as numbers)")
    p.set_defaults(func=_cmd_info)
