#!/usr/bin/env python3
"""Copies a GPGP checkout (the paper's implementation, github.com/baptiste-genest/GPGP) to OUT and makes the copy
build without its display and mesh libraries (docs/reference.md): src/Mesh.h, which needs geometry-central, becomes a
forward declaration of the Mesh type, and the one function that uses it (making dipoles from a triangle soup, which
the driver does not call) is compiled out. The checkout itself is not changed.

Two of its choices become switches read from the environment at run time, off by default (the copy then computes
what the checkout computes), so that the driver can show what each one changes (docs/reference.md#agreement):
  GPGP_EXACT_D3=1   the third derivative of its kernel with (I - 2 e e^T) in the term where it has (I - e e^T)
  GPGP_NO_FLOOR=1   the field's variance without the 1e-6 it adds when conditioning the gradient on the value

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


def replace_once(path: pathlib.Path, old: str, new: str) -> None:
    text = path.read_text()
    if text.count(old) != 1:
        raise SystemExit(f"prepare_gpgp.py: {path.name} does not hold exactly one '{old}' (another GPGP commit?)")
    path.write_text(text.replace(old, new))


def switch(name: str, on: str, off: str) -> str:
    """A C++ expression: `on` where the environment variable `name` is set, else `off`, read once (a static, so that
    the reference's timings do not change)."""
    return f'[] {{ static const double v = std::getenv("{name}") ? {on} : {off}; return v; }}()'


def add_switches(src: pathlib.Path) -> None:
    """The environment switches of the module's docstring, each where the checkout makes the choice."""
    kernel = src / "StochasticPoissonSurfaceReconstruction.h"
    replace_once(kernel, "(A/r)*edotn*(I - eeT)", "(A/r)*edotn*(I - " + switch("GPGP_EXACT_D3", "2.0", "1.0") + "*eeT)")
    kernel.write_text("#include <cstdlib>\n" + kernel.read_text())
    gaussians = src / "gaussians.h"
    for old in ("Cxy*(c - meanw)/(1e-6 + var)", "Cxy*Cxy.transpose()/(1e-6 + var)"):
        replace_once(gaussians, old, old.replace("1e-6", switch("GPGP_NO_FLOOR", "0.0", "1e-6")))
    gaussians.write_text("#include <cstdlib>\n" + gaussians.read_text())


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
    add_switches(out / "src")
    print(f"prepare_gpgp.py: {out} ready")
    return 0


if __name__ == "__main__":
    sys.exit(main())
