"""``esair std check FILE`` and ``esair std schema``: the deployment file."""

from __future__ import annotations

import json

import click

from esair_min.cli.pipes import friendly


@click.command()
@click.argument("file", metavar="FILE|NAME")
@click.option("--no-import", is_flag=True,
              help="Do not import the classes (their modules run code when imported).")
@friendly
def check(file: str, no_import: bool) -> None:
    """Check a deployment file and print a short summary.

    FILE is a deployment file, a folder holding FOLDER/FOLDER.yaml, or the name of a
    bundled example (lab, papaman, starfish).

    Every class is imported (from the file's folder first, then sys.path) unless
    --no-import is given. Notes (e.g. an allow naming a behavior the file does not
    list) are printed but do not fail the check.
    """
    from esair_std.deploy import load_classes, load_document, notes, resolve_deployment
    from esair_std.deploy.deployment_summary import deployment_summary

    dep, doc = load_document(resolve_deployment(file))
    if not no_import:
        classes = load_classes(dep)
    for line in deployment_summary(dep):
        click.echo(line)
    if not no_import:
        click.echo(f"  classes: {len(classes)} imported")
    for mark, text in notes(dep, doc):
        click.echo(f"note: {mark}: {text}")
    click.echo("ok")


@click.command()
@click.option("--indent", default=2, show_default=True, help="JSON indentation.")
def schema(indent: int) -> None:
    """Print the JSON Schema of the deployment file format (for editors)."""
    from esair_std.deploy import deployment_schema

    click.echo(json.dumps(deployment_schema(), indent=indent, sort_keys=True))


@click.command("new")
@click.argument("example", metavar="NAME")
@click.argument("folder", metavar="DIR")
@friendly
def new(example: str, folder: str) -> None:
    """Copy bundled example NAME (lab, papaman, starfish) into DIR: its deployment file and its
    behaviors' modules, to edit. The copy is a robot of its own: DIR/DIR.yaml, named after
    DIR, on a free loopback port; it passes `esair std check` and runs as is (`esair std run
    DIR`); the classes are imported from DIR first."""
    from esair_std.deploy.bundled import copy_example

    files, robot, endpoint = copy_example(example, folder)
    for path in files:
        click.echo(f"wrote {path}")
    click.echo(f"run it: esair std run {folder}")
    click.echo(f"robot {robot!r} listens on {endpoint}: other terminals give -e {endpoint} "
               f"(or export ESAIR_STD_ENDPOINT={endpoint})")


COMMANDS = (check, schema, new)
