"""PyYAML's indentation and structure errors, said in plain words at the mistake.

One fixture per common mistake under tests/fixtures/yaml_errors/: PAPA-MAN's central
board file with one mistake (described on its first line). Each message is asserted word
for word; none of them may keep PyYAML's parser jargon. The messages speak of YAML only
(ESAIR STD's files go through the same loader).
"""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from click.testing import CliRunner

from esair_min.cli import main
from esair_min.config.yamlload import load_yaml
from esair_min.errors import ConfigError

ROOT = Path(__file__).resolve().parents[2]
FIXTURES = Path("tests/fixtures/yaml_errors")

EXPECTED = {
    'alias_star':
        "8:14: '*' starts an alias (a reference to an '&' anchor); to write text that starts with '*', put it in quotes",
    'bad_escape':
        "8:25: '\\p' is not an escape YAML knows between double quotes; use single quotes for text with backslashes, or write '\\\\' for one backslash",
    'colon_in_value':
        '8:22: \': \' inside the value of \'description\' would start a second key on one line; put the value in quotes (description: "PAPA-MAN: central controller")',
    'key_at_list_column':
        "60:3: 'delay_ticks' stands at the column of the list's '-' items (line 53); a block holds either keys or '-' items, not both; indent it by 4 spaces like 'number' (line 59), or remove its indentation to place it beside 'motions' (line 52)",
    'key_less_indented':
        "60:4: 'delay_ticks' is indented 3 spaces, less than 'number' above it (line 59); indent it by 4 spaces like 'number', or remove its indentation to place it beside 'motions' (line 52)",
    'key_less_indented_block':
        "14:2: 'require_checksum' is indented 1 space, less than 'baud' above it (line 13); indent it by 2 spaces like 'baud', or remove its indentation to place it beside 'uart' (line 12)",
    'key_more_indented':
        "14:21: 'require_checksum' is indented 4 spaces, more than 'baud' above it (2 spaces, line 13), which already has a value; indent it by 2 spaces like 'baud'",
    'list_after_key':
        "46:14: a '-' list item cannot follow 'compare:' on the same line; start the list on the next line, indented below 'compare'",
    'list_item_among_keys':
        "50:5: a '-' list item among the keys of a block ('name', line 44): a block holds either keys or '-' items, not both; remove the '-' if this line is one more key, or put the items under a key of their own ('key:', the items indented below it)",
    'list_item_misaligned':
        "24:6: this '-' item is indented 5 spaces, but the item above it (line 23) is indented 4 spaces; indent every item of a list alike",
    'missing_colon':
        "13:3: 'baud 9600' has no ':', so YAML reads it and the next line as one text; write a key and its value as 'key: value' (a colon and a space after the key)",
    'missing_comma_in_flow':
        "30:40: a ':' inside {...} where ',' or '}' should come; separate the entries with ', ', or quote a value that holds ': '",
    'reserved_character':
        "8:14: '@' cannot start a value in YAML (it is reserved); put the value in quotes",
    'second_document':
        "52:1: a second YAML document starts here ('---'), but one document is expected; remove this line and what follows it, or merge the two",
    'tab_indent':
        '13:1: a tab character: YAML indents with spaces only; replace the tab by spaces',
    'text_after_quote':
        '8:25: text after the closing quote of a quoted value; put all of the value inside the quotes',
    'top_level_indented':
        "7:1: 'role' is not indented, but the first key of the file ('board', line 6) is indented 1 space; indent every top-level key alike (usually not at all)",
    'unclosed_flow_mapping':
        "23:7: this '{' starts a mapping that is not closed before line 24; end it with '}'",
    'unclosed_quote':
        '8:14: the " opened here is never closed; add the closing " at the end of the value',
}

JARGON = ("<block end>", "<block mapping start>", "could not find expected", "while parsing",
          "while scanning", "not allowed here", "cannot start any token", "YAML syntax error")


@pytest.fixture(autouse=True)
def _at_repo_root(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(ROOT)


@pytest.mark.parametrize("case", sorted(EXPECTED))
def test_yaml_mistake_in_plain_words(case: str) -> None:
    path = FIXTURES / f"{case}.yaml"
    with pytest.raises(yaml.YAMLError):            # the fixture really is broken YAML
        yaml.safe_load(path.read_text())
    with pytest.raises(ConfigError) as info:
        load_yaml(path)
    assert str(info.value) == f"{path}:{EXPECTED[case]}"
    assert not any(j in str(info.value) for j in JARGON)
    assert "board file" not in info.value.message   # generic to YAML, not to board files


def test_every_fixture_is_asserted() -> None:
    assert {p.stem for p in (ROOT / FIXTURES).glob("*.yaml")} == set(EXPECTED)


def test_the_position_is_pyyamls_except_where_it_is_not_on_the_mistake() -> None:
    """Same position as PyYAML, except a missing ':', a quote or '{' never closed, and a
    '*' that is not an alias: PyYAML points at the next line, the end of the file or
    the character after the '*'; the message points at the mistake."""
    moved = {"missing_colon", "unclosed_quote", "unclosed_flow_mapping", "alias_star"}
    for case in sorted(EXPECTED):
        text = (ROOT / FIXTURES / f"{case}.yaml").read_text()
        try:
            yaml.safe_load(text)
        except yaml.MarkedYAMLError as exc:
            m = exc.problem_mark
            same = EXPECTED[case].startswith(f"{m.line + 1}:{m.column + 1}: ")
            assert same != (case in moved), case


def test_esair_check_says_it_in_plain_words(tmp_path: Path) -> None:
    robot = tmp_path / "robot"
    robot.mkdir()
    for f in (ROOT / "boards" / "papaman").glob("*.yaml"):
        (robot / f.name).write_text(f.read_text())
    (robot / "central.yaml").write_text((ROOT / FIXTURES / "key_at_list_column.yaml").read_text())
    r = CliRunner().invoke(main, ["check", str(robot)])
    assert r.exit_code == 1
    assert r.stderr == f"error: {robot / 'central.yaml'}:{EXPECTED['key_at_list_column']}\n"
