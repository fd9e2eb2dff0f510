"""The ``hopmatch`` command group: global options (``--version``, ``--quiet``,
``--debug``), warnings shown as one line each for the whole run
(:func:`~hopmatch.cli.reporting.cli_warnings`), and the commands that live in plugins,
imported when first used (their help in plain text)."""

from __future__ import annotations

import importlib

import click

from ..feature.detector import DericheMoravecDetector
from ..matching.matcher import HopfieldMatcher
from .options import param_labels
from .outputs import versions
from .reporting import cli_warnings, plain_text, status

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
            _plain_help(cmd)
        return cmd


def _plain_help(cmd: click.Command) -> None:
    """A plugin command's help and its options' help in plain text (:func:`plain_text`)."""
    labels = param_labels(DericheMoravecDetector, HopfieldMatcher)
    if cmd.help:
        cmd.help = "\n\n".join(plain_text(par, labels) for par in cmd.help.split("\n\n"))
    for param in cmd.params:
        if getattr(param, "help", None):
            param.help = plain_text(param.help, labels)


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
    Warnings are one line each on stderr, 'hopmatch: warning: ...', even with --quiet.
    """
    labels = param_labels(DericheMoravecDetector, HopfieldMatcher)
    ctx.obj = {"quiet": quiet, "debug": debug, "labels": labels}
    status.quiet = quiet
    ctx.with_resource(cli_warnings(labels, debug))
