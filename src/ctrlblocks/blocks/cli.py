"""``ctrlblocks compile``: build, show or remove the optional compiled blocks."""

from __future__ import annotations

import click

from .. import compiled


@click.command("compile")
@click.option("--status", "show", is_flag=True, help="Only say whether a build is in use, and why.")
@click.option(
    "--check",
    is_flag=True,
    help="Check that a build is in use and computes what the interpreted blocks do (else exit 1).",
)
@click.option("--force", is_flag=True, help="Build again even if one exists for this source.")
@click.option("--remove", "drop", is_flag=True, help="Delete every build (interpreted blocks).")
@click.option(
    "--jobs", type=click.IntRange(1, 64), default=None, help="C compilers at once (default: cores)."
)
def compile_command(show: bool, check: bool, force: bool, drop: bool, jobs: int | None) -> None:
    """Build the optional compiled PID and ADRC blocks (Cython) for this Python and source.

    The build goes to the user's cache folder (or $CTRLBLOCKS_COMPILED_DIR),
    keyed by the blocks' source, and is used by every later 'import
    ctrlblocks' of this Python; $CTRLBLOCKS_COMPILED=off runs the interpreted
    blocks anyway.  Needs Cython (pip install 'ctrlblocks[compiled]') and a C
    compiler; takes 1-3 minutes.
    """
    if drop:
        gone = compiled.remove()
        click.echo(f"removed {len(gone)} build(s) from {compiled.build_root()}")
        return
    if check:  # what the release CI runs on every binary wheel (docs/performance.md)
        from ..testing import buildcheck

        try:
            click.echo(buildcheck.check())
        except compiled.BuildError as exc:
            raise click.ClickException(str(exc)) from None
        return
    if show:
        import ctrlblocks  # noqa: F401  (loads the build, if any)

        st = compiled.status()
        state = "in use" if st["active"] else "not in use"
        click.echo(f"compiled blocks: {state}: {st['reason']} (CTRLBLOCKS_COMPILED={st['mode']})")
        return
    try:
        compiled.build(jobs=jobs, force=force)
    except compiled.BuildError as exc:
        raise click.ClickException(str(exc)) from None
    except OSError as exc:  # a full disk, a folder that cannot be written, ...
        raise click.ClickException(f"{exc.strerror or exc}: {exc.filename or ''}") from None
