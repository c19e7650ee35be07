#!/usr/bin/env python3
"""Checks the module layering of docs/architecture.md on every #include.

  1. A module includes only its own headers and those of modules of a lower layer.
  2. A header under <module>/internal/ is included only from <module> and its tests
     (tests/<module>/).

Usage: check_layers.py SOURCE_DIR. Prints each violation; exit status 1 if any (the
build runs it: CMakeLists.txt, target `layering`).
"""
import os
import re
import sys

# Layer of each module, lowest first; a module may include modules of a lower layer.
LAYERS = {
    "core/common": 0,
    "core/model": 1,
    "core/io": 2,
    "core/store": 2,
    "core/sim": 3,
    "core/filter": 3,
    "core/video": 3,
    "core/estimate": 4,
    "core/diagnose": 5,
    "core/jobs": 6,
    "core/analysis": 7,
    "proto": 8,
    "server": 9,
    "worker": 10,
    "client": 10,
}
INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)


def module_of(path):
    """The module a repository path belongs to, or None."""
    if path.startswith("wormdrag/"):  # generated from proto/wormdrag/
        return "proto"
    parts = path.split("/")
    name = "/".join(parts[:2]) if parts[0] == "core" else parts[0]
    return name if name in LAYERS else None


def main(root):
    errors = []
    for top in ["core", "proto", "server", "worker", "client", "tests", "bench"]:
        for dirpath, _, files in os.walk(os.path.join(root, top)):
            for f in files:
                if not f.endswith((".cc", ".h")):
                    continue
                path = os.path.relpath(os.path.join(dirpath, f), root)
                with open(os.path.join(root, path), encoding="utf-8", errors="replace") as fh:
                    text = fh.read()
                test_of = path[len("tests/"):] if path.startswith("tests/") else None
                src = module_of(test_of or path)
                for inc in INCLUDE.findall(text):
                    dst = module_of(inc)
                    if dst is None or dst == src:
                        continue
                    if "/internal/" in inc:
                        errors.append(f"{path}: includes {inc}, internal to {dst}")
                    elif top in ("core", "proto", "server", "worker", "client") and src is not None \
                            and LAYERS[dst] >= LAYERS[src]:
                        errors.append(f"{path}: {src} (layer {LAYERS[src]}) includes {inc} "
                                      f"of {dst} (layer {LAYERS[dst]})")
    for e in errors:
        print(e)
    if errors:
        print(f"{len(errors)} layering violation(s): see docs/architecture.md")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else "."))
