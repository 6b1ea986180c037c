"""The checking child's pydantic import (esair_std/lean/checked.py): without asyncio, and
leaving nothing of its stand-in behind."""

from __future__ import annotations

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
