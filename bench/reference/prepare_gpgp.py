#!/usr/bin/env python3
"""Copies a GPGP checkout (the paper's implementation, github.com/baptiste-genest/GPGP) to OUT and makes the copy
build without its display and mesh libraries (docs/reference.md): src/Mesh.h, which needs geometry-central, becomes a
forward declaration of the Mesh type, and the one function that uses it (making dipoles from a triangle soup, which
the driver does not call) is compiled out. The checkout itself is not changed.

Usage: prepare_gpgp.py GPGP_CHECKOUT OUT
"""
import pathlib
import shutil
import sys

MESH_STUB = """// Written by gpisvdb's bench/reference/prepare_gpgp.py: the headless build needs only the name of the mesh type.
#ifndef MESH_H
#define MESH_H
#include "types.h"
#include "sampling.h"
namespace SGP { struct Mesh; }
#endif
"""
SOUP_FUNCTION = "SGP::GaussianDipoles<3> SGP::GaussianDipolesFromTriangleSoup("


def compile_out(text: str, signature: str) -> str:
    """Wraps the function that starts at `signature` (to its matching closing brace) in #ifndef GPGP_HEADLESS."""
    start = text.index(signature)
    depth, i = 0, text.index("{", start)
    while True:
        depth += {"{": 1, "}": -1}.get(text[i], 0)
        i += 1
        if depth == 0:
            break
    return text[:start] + "#ifndef GPGP_HEADLESS\n" + text[start:i] + "\n#endif  // GPGP_HEADLESS\n" + text[i:]


def main() -> int:
    if len(sys.argv) != 3:
        print(__doc__, file=sys.stderr)
        return 2
    src, out = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2])
    if not (src / "src" / "NarrowBand.cpp").is_file():
        print(f"prepare_gpgp.py: {src} is not a GPGP checkout (no src/NarrowBand.cpp)", file=sys.stderr)
        return 1
    if out.exists():
        shutil.rmtree(out)
    shutil.copytree(src, out, ignore=shutil.ignore_patterns(".git", "build*"))
    for p in out.rglob("*"):
        if p.is_file():
            p.chmod(0o644)
    (out / "src" / "Mesh.h").write_text(MESH_STUB)
    cloud = out / "src" / "GaussianPointCloud.cpp"
    cloud.write_text(compile_out(cloud.read_text(), SOUP_FUNCTION))
    print(f"prepare_gpgp.py: {out} ready")
    return 0


if __name__ == "__main__":
    sys.exit(main())
