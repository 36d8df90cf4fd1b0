"""``facepair face``: the renderer's faces as files other tools open."""

from __future__ import annotations

import click


@click.group("face")
def face() -> None:
    """Export the built-in head (glTF 2.0 with ARKit blendshapes)."""


@face.command("export")
@click.option(
    "--out", required=True, type=click.Path(dir_okay=False), help="Output .glb (binary glTF 2.0)."
)
def export(out: str) -> None:
    """Write the built-in head as a glTF avatar: ARKit-named morph targets, a head and two
    eye bones, feature points in its extras (docs/reference/renderer.md, "Avatars")."""
    from app.errors import InputError
    from renderer.faceexport import export_builtin_head

    if not out.lower().endswith(".glb"):
        raise InputError("the head is written as binary glTF: name it *.glb", field="--out")
    path = export_builtin_head(out)
    click.echo(f"{path}: the built-in head as glTF 2.0 with ARKit blendshapes")
