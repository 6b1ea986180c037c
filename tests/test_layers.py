"""The packages' import arrows only point down, and nothing imports in a circle
(issue 25 item 4). The graph is read with ``ast`` (tests/support/imports.py), lazy
imports inside functions included."""

from tests.support.imports import cycles, graph, modules

#: modules run only as ``python -m ...`` (a command's front door): they may use the CLI
ENTRY_POINTS = {"esair_min.harness"}


def _arrows():
    return [(a, b) for a, targets in graph().items() for b in sorted(targets)]


def test_no_module_imports_in_a_circle():
    assert cycles(graph()) == []


def test_min_never_imports_std():
    assert [(a, b) for a, b in _arrows()
            if a.startswith("esair_min") and b.startswith("esair_std")] == []


def test_only_commands_import_the_command_line():
    def is_cli(m: str) -> bool:
        return ".cli" in f".{m.split('.', 1)[1]}" if "." in m else False

    assert [(a, b) for a, b in _arrows()
            if is_cli(b) and not is_cli(a) and a not in ENTRY_POINTS] == []


def test_the_generator_reads_only_the_model():
    """codegen (installed as esair_min.codegen) reads the model (its device kinds
    included) and the protocol's numbers; it never reaches into the emulator, the PIC
    tools or a command (the cache folder's place, a leaf, for its build ids)."""
    allowed = ("esair_min.codegen", "esair_min.model", "esair_min.components",
               "esair_min.core.image", "esair_min.core.protocol", "esair_min.errors",
               "esair_min.resources", "esair_min.cachedir")
    assert [(a, b) for a, b in _arrows() if a.startswith("esair_min.codegen")
            and b != "esair_min" and not b.startswith(allowed)] == []


def test_the_walk_sees_every_package():
    """The checks above can fail: the walk finds the modules and their arrows."""
    mods = modules()
    assert {"esair_min.cli", "esair_std.cli", "esair_min.codegen.context",
            "esair_std.transport.bus"} <= set(mods)
    arrows = set(_arrows())
    assert ("esair_std.drivers.minlink.link", "esair_min.core.protocol") in arrows or any(
        a.startswith("esair_std.drivers.minlink") and b.startswith("esair_min")
        for a, b in arrows)
    assert cycles({"a": {"b"}, "b": {"a"}, "c": set()}) == [["a", "b"]]
