"""Every `esair ...` command the README and docs/*.md show in a code block is checked as a
user would type it (issue 34 item 5: `robot.yaml` and `locate:Locate` existed nowhere):

- it parses: the command exists and takes those options and arguments (click's own
  parser, the options' own checks: an endpoint's form, a number's range);
- a deployment it names (`run`, `check`, `inspect`...: a FILE argument) is found — a
  bundled example, a file of the checkout, or a folder an `esair std new` of the same
  block made — and loads, with every class imported;
- a `module:Class` it names (`agent`, `add`) is imported;
- `esair std new` and `esair std check` are run for real (in a scratch folder).

Lines of the form `$ esair ...` count too; output lines do not. A document's commands
are checked in order, as a reader follows them. A block may hold lines that are not
commands (comments, output): only lines that start with `esair ` are read,
joined with their `\\` continuations."""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import click
import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
FENCE = re.compile(r"^\s*```")


def blocks(text: str) -> list[tuple[int, list[str]]]:
    """(first line number, lines) of each fenced block and each 4-space indented block."""
    out: list[tuple[int, list[str]]] = []
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        if FENCE.match(lines[i]):
            j = i + 1
            while j < len(lines) and not FENCE.match(lines[j]):
                j += 1
            out.append((i + 2, lines[i + 1:j]))
            i = j + 1
        elif lines[i].startswith("    ") and (i == 0 or not lines[i - 1].strip()):
            j = i
            while j < len(lines) and (lines[j].startswith("    ") or not lines[j].strip()):
                j += 1
            out.append((i + 1, [ln[4:] for ln in lines[i:j]]))
            i = j
        else:
            i += 1
    return out


#: what ends one command of a shell line: `a; b`, `a && b`, `a &`, `a | b`
OPERATORS = {";", "&&", "||", "&", "|"}
#: a redirection: `a > out.json`, `a 2> err`, `a < in`
REDIRECTS = {">", ">>", "<", "&>"}


def commands(lines: list[str], first: int) -> list[tuple[int, str]]:
    """(line number, command) of each `esair ...` command of a line that starts with one,
    continuations joined, a line of several commands split at its operators."""
    out, i = [], 0
    while i < len(lines):
        line = lines[i].strip()
        if line.startswith("$ "):
            line = line[2:]
        n = first + i
        if line.startswith("esair "):
            while line.endswith("\\") and i + 1 < len(lines):
                i += 1
                line = line[:-1] + " " + lines[i].strip()
            lex = shlex.shlex(line, posix=True, punctuation_chars=";&|<>")
            lex.whitespace_split, lex.commenters = True, "#"
            words: list[str] = []
            redirect = False
            for token in [*lex, ";"]:
                if token in OPERATORS:
                    if words and words[0] == "esair":
                        out.append((n, shlex.join(words)))
                    words = []
                elif token in REDIRECTS:
                    redirect = True          # the file after it is the shell's
                    if words and words[-1].isdigit() and len(words) > 1:
                        words.pop()          # `2> err`: the descriptor's number
                elif redirect:
                    redirect = False
                else:
                    words.append(token)
        i += 1
    return out


def examples() -> list[tuple[str, list[tuple[int, str]]]]:
    """Per document, its commands in order (a folder an `esair std new` made is there for
    the document's later blocks, as for a reader who follows it)."""
    found = []
    for doc in DOCS:
        cmds = [c for first, lines in blocks(doc.read_text()) for c in commands(lines, first)]
        if cmds:
            found.append((str(doc.relative_to(ROOT)), cmds))
    return found


def parse(args: list[str]) -> tuple[list[str], dict]:
    """The command path (["std", "run"]) and its parameters, as click parses them."""
    from esair_min.cli import main
    cmd: click.Command = main
    path: list[str] = []
    with click.Context(main, info_name="esair") as parent:
        ctx = cmd.make_context("esair", list(args), parent=parent)
        while isinstance(cmd, click.Group):
            # click 8.2 keeps the subcommand apart (protected_args, deprecated; click 9: args)
            rest = [*getattr(ctx, "_protected_args", []), *ctx.args]
            name, sub, rest = cmd.resolve_command(ctx, rest)
            assert sub is not None and name is not None
            path.append(name)
            cmd = sub
            ctx = cmd.make_context(name, rest, parent=ctx)
        return path, dict(ctx.params)


#: parameters that name a deployment (FILE|NAME), per command
DEPLOYMENT_PARAMS = {("std", "run"): "deployment", ("std", "check"): "file"}
#: parameters that name a class module:Class
CLASS_PARAMS = {("std", "agent"): "class_path", ("std", "add"): "class_path"}


def check(cmd: str, made: dict[str, Path], scratch: Path) -> str | None:
    """Why ``cmd`` would not run as written, or None."""
    from esair_std.classes import load_class
    from esair_std.deploy import load_classes, load_document, resolve_deployment
    from esair_std.endpoint import reaches_beyond
    from esair_std.errors import StdError
    args = shlex.split(cmd)[1:]
    try:
        path, params = parse(args)
    except click.ClickException as exc:
        return f"does not parse: {exc.format_message()}"
    key = tuple(path)
    if key == ("std", "record"):          # what a later `replay` of the block reads
        Path(params["out"]).touch()
    if key == ("std", "new"):
        folder = scratch / params["folder"]
        r = subprocess.run([sys.executable, "-m", "esair_min.cli", "std", "new",
                            params["example"], str(folder)], capture_output=True, text=True,
                           cwd=scratch, env=dict(os.environ, PYTHONPATH=str(ROOT)))
        if r.returncode:
            return f"failed: {r.stderr.strip()}"
        made[params["folder"]] = folder
        return None
    dep = None
    if key in DEPLOYMENT_PARAMS:
        arg = params[DEPLOYMENT_PARAMS[key]]
        where = made.get(arg) or (ROOT / arg if (ROOT / arg).exists() else None)
        try:
            dep, _ = load_document(resolve_deployment(where or arg))
            load_classes(dep)
        except StdError as exc:
            return f"its deployment {arg!r}: {exc}"
    # an address other computers reach, without security: refused unless --insecure
    endpoint = None
    if key == ("std", "run") and dep is not None and not params.get("no_control"):
        endpoint = params.get("endpoint") or dep.endpoint
        secured = dep.security is not None and (dep.security.users or dep.security.cert)
    elif key == ("std", "agent"):
        endpoint, secured = params["endpoint"], params.get("user") or params.get("cert")
    if endpoint and reaches_beyond(endpoint) and not secured and not params.get("insecure"):
        return f"refused: {endpoint} reaches other computers without security (no --insecure)"
    if key in CLASS_PARAMS:
        try:
            load_class(params[CLASS_PARAMS[key]], ROOT)
        except StdError as exc:
            return f"its class: {exc}"
    return None


EXAMPLES = examples()


def test_the_docs_show_commands():
    """The extraction can fail: it finds the README's and the docs' commands."""
    where = {w for w, _ in EXAMPLES}
    assert {"README.md", "docs/std.md", "docs/std-network.md", "docs/std-starfish.md"} <= where
    assert sum(len(c) for _, c in EXAMPLES) > 50


def test_a_wrong_example_is_caught(tmp_path):
    made: dict[str, Path] = {}
    assert check("esair std run robot.yaml --mode process", made, tmp_path) == (
        "its deployment 'robot.yaml': robot.yaml: no such file or folder")
    assert check("esair std agent --connect tcp/10.0.0.1:7447 --insecure locate locate:Locate",
                 made, tmp_path).startswith("its class: no module named 'locate'")
    assert check("esair std run lab --mdoe process", made, tmp_path).startswith(
        "does not parse: No such option '--mdoe'")
    assert check("esair std run lab -e tcp/10.0.0.1:7447", made, tmp_path) == (
        "refused: tcp/10.0.0.1:7447 reaches other computers without security (no --insecure)")
    assert check("esair std run lab -e tcp/10.0.0.1:7447 --insecure", made, tmp_path) is None
    assert commands(["esair verify mybot --json > verify.json 2> err"], 9) == [
        (9, "esair verify mybot --json")]
    assert commands(["esair std ls; esair std get logger   # two", "output line",
                     "$ esair emulate starfish --pty &", "esair std agent --connect \\",
                     "    tcp/127.0.0.1:7447 x m:C"], 1) == [
        (1, "esair std ls"), (1, "esair std get logger"), (3, "esair emulate starfish --pty"),
        (4, "esair std agent --connect tcp/127.0.0.1:7447 x m:C")]


@pytest.mark.parametrize("where,cmds", EXAMPLES, ids=[w for w, _ in EXAMPLES])
def test_every_example_runs_as_written(where, cmds, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    made: dict[str, Path] = {}
    wrong = [f"{where}:{n}: {cmd}\n    {why}" for n, cmd in cmds
             if (why := check(cmd, made, tmp_path)) is not None]
    assert wrong == [], "\n".join(wrong)
