"""The ``hopmatch`` command group: global options (``--version``, ``--quiet``,
``--debug``) and the commands that live in plugins, imported when first used."""

from __future__ import annotations

import importlib

import click

from .outputs import versions
from .reporting import status

__all__ = ["PluginGroup", "cli"]


def _print_version(ctx, param, value):
    if not value or ctx.resilient_parsing:
        return
    v = versions()
    click.echo(f"hopmatch {v['hopmatch']} (opencv {v['opencv']}, numpy {v['numpy']}, "
               f"numba {v['numba']}, python {v['python']})")
    ctx.exit(0)


class PluginGroup(click.Group):
    """The command group, plus commands that live in plugins (``hopmatch batch`` is
    ``hopmatch_dask.cli.batch``), imported only when used so that the other commands do not
    pay for importing Dask."""

    #: Command name -> (module, attribute, what to install when the import fails).
    PLUGINS = {"batch": ("hopmatch_dask.cli", "batch", "hopmatch[dask]")}

    def list_commands(self, ctx):
        return sorted(set(super().list_commands(ctx)) | set(self.PLUGINS))

    def get_command(self, ctx, name):
        cmd = super().get_command(ctx, name)
        if cmd is None and name in self.PLUGINS:
            module, attr, extra = self.PLUGINS[name]
            try:
                cmd = getattr(importlib.import_module(module), attr)
            except ImportError as exc:
                raise click.UsageError(
                    f"`hopmatch {name}` needs its plugin: pip install '{extra}' ({exc})"
                ) from None
        return cmd


@click.group(cls=PluginGroup,
             context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100})
@click.option("--version", is_flag=True, expose_value=False, is_eager=True,
              callback=_print_version, help="Show the versions and exit.")
@click.option("--quiet", "-q", is_flag=True,
              help="No progress line on stderr and no summary on stdout (errors still shown).")
@click.option("--debug", is_flag=True, help="Show the full traceback of errors.")
@click.pass_context
def cli(ctx, quiet, debug):
    """Sparse stereo matching: Moravec points on a Canny-Deriche gradient, matched by a
    Hopfield network (Achour & Mahiddine, 2002).

    Run 'hopmatch demo' for a first look, 'hopmatch COMMAND --help' for the options.
    """
    ctx.obj = {"quiet": quiet, "debug": debug}
    status.quiet = quiet
