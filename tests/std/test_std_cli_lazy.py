"""`esair std` imports a command's module only when that command runs (esair_std.cli.LAZY):
every CLI call the suite and a user make started an interpreter that imported every
command (the HMI's web server, the runtime, the certificate tools) for one `ls`."""

from __future__ import annotations

import importlib
import json
import subprocess
import sys

import click

from esair_std import cli

MODULES = ("deploy", "run", "control", "top", "agent", "certs", "hmi", "foxglove")


def test_the_lazy_table_holds_every_command_the_modules_define():
    defined = {}
    for module in MODULES:
        mod = importlib.import_module(f"esair_std.cli.{module}")
        for attr, value in vars(mod).items():
            if isinstance(value, click.Command) and value.name is not None:
                defined.setdefault(value.name, f"{module}:{attr}")
    assert {name: defined[name] for name in cli.LAZY} == cli.LAZY
    assert sorted(cli.LAZY) == sorted(defined)


def _loaded_by(*args: str) -> list[str]:
    code = ("import sys, json\nfrom esair_min.cli import main\n"
            "try:\n    main([*sys.argv[1:]], standalone_mode=False)\nexcept SystemExit:\n    pass\n"
            "print(json.dumps(sorted(m for m in sys.modules if m.startswith('esair_std.cli.'))))")
    r = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True,
                       timeout=60, check=True)
    return json.loads(r.stdout.splitlines()[-1])


def test_a_command_imports_its_own_module_only():
    commands = {f"esair_std.cli.{m}" for m in MODULES}
    assert commands & set(_loaded_by("std", "ls", "--help")) == {"esair_std.cli.control"}
    assert commands & set(_loaded_by("std", "hmi", "--help")) == {"esair_std.cli.hmi"}
    # the group's help names every command's help
    assert commands <= set(_loaded_by("std", "--help"))
