"""docs/python.md against the module: every keyword of every function and method is named there, in a signature
(`name(kw, …)`, `kw=default`) or as `kw`."""
import pathlib
import re

import gpisvdb

DOC = (pathlib.Path(__file__).resolve().parents[2] / "docs" / "python.md").read_text()


def keywords(obj):
    """The keyword names of every pybind11 signature in obj's docstring (`name(a: T, *, b: U = …) -> R`)."""
    for signature in re.findall(r"\(([^)]*)\)\s*->", obj.__doc__ or ""):
        for part in signature.split(","):
            m = re.match(r"\s*(\w+)\s*:", part)
            if m and m.group(1) != "self":
                yield m.group(1)


def test_every_keyword_of_the_module_is_named_in_python_md():
    core = gpisvdb._core
    objects = []
    for name in dir(core):
        obj = getattr(core, name)
        if name.startswith("_") or not callable(obj):
            continue
        objects.append((name, obj))
        if isinstance(obj, type):
            objects += [(name + "." + m, getattr(obj, m)) for m in dir(obj) if not m.startswith("_")]
    assert len(objects) > 40
    missing = sorted({f"{name}({kw})" for name, obj in objects for kw in keywords(obj)
                      if not re.search(r"[(, ]" + kw + r"[,)=]|`" + kw + "`", DOC)})
    assert not missing, "keywords docs/python.md does not name: " + ", ".join(missing)
