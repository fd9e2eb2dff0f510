"""Options generated from the parameters (hopmatch.cli.options), through the real entry point."""

from __future__ import annotations

import pytest
from cli_helpers import assert_bad_input, run

from hopmatch import DericheMoravecDetector, HopfieldMatcher


def test_match_help_has_an_option_for_every_parameter():
    res = run("match", "--help")
    assert res.returncode == 0, res.stderr
    for spec in DericheMoravecDetector.PARAMS + HopfieldMatcher.PARAMS:
        flag = "--" + spec.name.replace("_", "-")
        assert flag in res.stdout, flag
        if isinstance(spec.default, bool):
            assert "--no-" + spec.name.replace("_", "-") in res.stdout
    for flag in ("--out", "--format", "--no-draw", "--plot-energy", "--preset"):
        assert flag in res.stdout
    detect_help = run("detect", "--help").stdout
    assert "--window-size" in detect_help and "--max-disparity" not in detect_help


BAD_OPTIONS = [  # (extra arguments, words the message must hold)
    (["--window-size", "4"], ["--window-size", "odd", "4"]),
    (["--window-size", "abc"], ["--window-size", "abc"]),
    (["--preset", "fancy"], ["--preset", "fancy", "paper"]),
    (["--on", "colour"], ["--on", "gradient"]),
    (["--alpha", "0"], ["--alpha"]),
    (["--similarity-gate", "-1"], ["--similarity-gate"]),
    (["--max-disparity", "nan"], ["--max-disparity"]),
    # Python's int() and float() read these as 10 and 12: plain ASCII numbers only
    (["--max-disparity", "1_0"], ["--max-disparity", "1_0", "not a number"]),
    (["--window-size", "\u0661\u0663"], ["--window-size", "not an integer"]),
    (["--format", "xml"], ["--format", "xml"]),
    (["--bogus"], ["--bogus", "no such option"]),
    # only found while running: the output folder exists by then and must be cleaned up
    (["--min-disparity", "20", "--max-disparity", "10"], ["--max-disparity", "--min-disparity"]),
    (["--max-neurons", "1"], ["--max-neurons"]),
]


@pytest.mark.parametrize("extra, words", BAD_OPTIONS, ids=[" ".join(b[0]) for b in BAD_OPTIONS])
def test_bad_option(pair, tmp_path, extra, words):
    out = tmp_path / "a" / "out"
    res = run("match", pair["left"], pair["right"], "--out", out, *extra)
    line = assert_bad_input(res, *words)
    assert line.startswith(f"hopmatch: error: {words[0]}: ")
    assert not (tmp_path / "a").exists()  # folders created by the failed run are removed


@pytest.mark.parametrize("command", [["warmup", "--processes"], ["eval", "--repeat"]])
def test_count_options_take_plain_integers(command):
    # click.IntRange reads "1_0" as 10 (Python's int()); hopmatch's counts do not
    assert_bad_input(run(*command, "1_0"), command[-1], "1_0", "not an integer")


def test_missing_out_option(pair):
    assert_bad_input(run("match", pair["left"], pair["right"]), "--out", "missing")


# --------------------------------------------------------------------------------------
# The options come from the Param fields (kind, choices, optional, doc)
# --------------------------------------------------------------------------------------


def _command(*classes):
    import click

    from hopmatch.cli.options import given_parameters, parameter_options

    @click.command()
    @parameter_options(*classes)
    def cmd(**params):
        click.echo(repr(sorted(given_parameters(params, *classes).items())))

    return cmd


def test_option_types_follow_the_param_kinds():
    from click.testing import CliRunner

    from hopmatch.cli.options import ParamType

    by_name = {p.name: p for p in DericheMoravecDetector.PARAMS + HopfieldMatcher.PARAMS}
    assert ParamType(by_name["window_size"]).get_metavar(None) == "INT"
    assert ParamType(by_name["alpha"]).get_metavar(None) == "FLOAT"
    assert ParamType(by_name["on"]).get_metavar(None) == "[gradient|intensity]"
    cmd = _command(DericheMoravecDetector, HopfieldMatcher)
    res = CliRunner().invoke(cmd, ["--window-size", "5", "--max-disparity", "none",
                                   "--no-subpixel", "--on", "intensity"])
    assert res.exit_code == 0, res.output
    assert res.output.strip() == repr(sorted({"window_size": 5, "max_disparity": None,
                                              "subpixel": False, "on": "intensity"}.items()))
    assert CliRunner().invoke(cmd, ["--window-size", "none"]).exit_code == 2  # not optional


def test_option_help_is_the_param_doc():
    from click.testing import CliRunner

    from hopmatch._params import Configurable, Param, integer

    class Thing(Configurable):
        PARAMS = (Param("size", 3, integer(1, optional=True), "How big, in pixels."),)

    res = CliRunner().invoke(_command(Thing), ["--help"], terminal_width=200)
    assert "How big, in pixels. [matcher; default 3; 'none' for None]" in res.output
    assert _command(Thing).params[0].type.kind == "int"


# --------------------------------------------------------------------------------------
# Help: every option explained, in plain text (issue 19, point 5)
# --------------------------------------------------------------------------------------

COMMANDS = ["demo", "match", "detect", "eval", "batch"]


def _click_command(name):
    import click

    from hopmatch.cli import cli

    ctx = click.Context(cli)
    return cli.get_command(ctx, name)


@pytest.mark.parametrize("name", COMMANDS)
def test_every_option_has_help(name):
    import click

    cmd = _click_command(name)
    missing = [p.name for p in cmd.params
               if isinstance(p, click.Option) and not (p.help or "").strip()]
    assert not missing, f"hopmatch {name}: options without help: {missing}"


@pytest.mark.parametrize("name", COMMANDS)
def test_help_is_plain_text(name):
    res = run(name, "--help")
    assert res.returncode == 0, res.stderr
    for markup in (":func:", ":class:", ":mod:", ":meth:", ":data:", "``", "`~"):
        assert markup not in res.stdout, (markup, name)
    assert "--max-vertical" not in res.stdout or "Half-height" in res.stdout
