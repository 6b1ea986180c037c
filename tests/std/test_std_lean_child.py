"""The checking child's pydantic (esair_std/lean/checked.py): imported without asyncio,
leaving nothing of its stand-in behind; no plugin scan, and no importlib.metadata."""

from __future__ import annotations

import json
import subprocess
import sys

PROGRAM = r"""
import sys, warnings
from esair_std.lean.checked import _pydantic_without_asyncio
_pydantic_without_asyncio()
assert "pydantic.main" in sys.modules
assert "asyncio" not in sys.modules and "asyncio.coroutines" not in sys.modules, "stand-in left"
import asyncio, asyncio.coroutines
assert asyncio.__file__ and hasattr(asyncio, "run"), "a stand-in, not asyncio"
import pydantic

class M(pydantic.BaseModel):
    x: int

with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    assert M(x=1).dict() == {"x": 1}       # a method pydantic marked deprecated
assert any("deprecated" in str(w.message) for w in caught)

async def co():
    return 1

assert asyncio.run(co()) == 1
print("ok")
"""


def test_pydantic_imported_without_asyncio_and_the_real_one_after():
    out = subprocess.run([sys.executable, "-c", PROGRAM], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "ok"


CHECK = r"""
import json, os, sys
os.environ.pop("PYDANTIC_DISABLE_PLUGINS", None)
from esair_std.lean import checked
answer = checked._check(sys.argv[1], None)
print(json.dumps({"answer": answer, "left": [m for m in ("asyncio", "importlib.metadata")
                                             if m in sys.modules]}))
"""


def test_the_check_needs_neither_asyncio_nor_importlib_metadata(tmp_path):
    dep = tmp_path / "deployment.yaml"
    dep.write_text(json.dumps({"robot": "t", "resources": {"count": {
        "class": "tests.support.comps:Counter", "allow": {"*": "read"}}}, "behaviors": {
        "w": {"class": "tests.support.comps:Watcher", "uses": {"count": "read"}}}}))
    out = subprocess.run([sys.executable, "-c", CHECK, str(dep)], capture_output=True,
                         text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    got = json.loads(out.stdout)
    assert got["left"] == []
    plain = got["answer"]["deployment"]
    assert plain["robot"] == "t"
    assert sorted(spec["name"] for spec in plain["specs"]) == ["count", "w"]
