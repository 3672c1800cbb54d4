"""The command's docs are true: every ``--param`` example in docs/ and the README is
accepted by the command, the worked example of ``ppaloc score`` runs and prints what the
page shows, and the page's formats and messages are the command's own."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from ppaloc.cli import main

ROOT = Path(__file__).resolve().parents[2]
PAGES = [*sorted((ROOT / "docs").glob("*.md")), ROOT / "README.md"]
CLI_DOC = (ROOT / "docs" / "evaluate-cli.md").read_text()

_PLACEHOLDERS = {"N": "8"}  # `alpha=N`: any number the text discusses


def _param_examples() -> list[tuple[str, str]]:
    """(page, value) of every ``--param VALUE`` written in the docs, quotes removed;
    the syntax placeholders (``METHOD.KEY=VALUE``) left out."""
    out = []
    for page in PAGES:
        for m in re.finditer(r"--param\s+(\"[^\"]*\"|'[^']*'|[^\s`]+)", page.read_text()):
            value = shlex.split(m.group(1))[0]  # its quotes removed as the shell does
            if "KEY=VALUE" in value:
                continue
            out.append((page.name, value))
    return out


EXAMPLES = _param_examples()


def test_the_docs_have_param_examples():
    assert len(EXAMPLES) >= 8
    assert ("localise.md", "particle-filter.size=(8,8)") in EXAMPLES


@pytest.mark.parametrize(("page", "value"), EXAMPLES, ids=[f"{p}:{v}" for p, v in EXAMPLES])
def test_every_param_example_is_accepted_by_the_command(page, value, monkeypatch, capsys):
    """Through `ppaloc evaluate`'s own parsing and checks (the run itself replaced)."""
    import ppaloc.cli.commands as commands

    ran = []
    monkeypatch.setattr(commands, "run_evaluate", lambda config, *a, **k: ran.append(config))
    key, _, raw = value.partition("=")
    raw = _PLACEHOLDERS.get(raw, raw)
    method = key.rpartition(".")[0]
    values = [raw]
    if page == "sweep.md" and raw.startswith("["):  # a sweep's list is an axis of values
        values = [v.strip() for v in raw.strip("[]").split(",")]
    for v in values:
        argv = ["evaluate", "-d", "synthetic:?places=6", "-m", method, "--param", f"{key}={v}"]
        code = main(argv)
        assert code == 0, capsys.readouterr().err
    assert len(ran) == len(values)


def test_a_parenthesised_tuple_is_the_list_it_writes(monkeypatch):
    import ppaloc.cli.commands as commands

    ran = []
    monkeypatch.setattr(commands, "run_evaluate", lambda config, *a, **k: ran.append(config))
    for text in ("(8,8)", "( 8, 8 )", "[8, 8]"):
        argv = ["evaluate", "-d", "synthetic", "-m", "particle-filter"]
        assert main([*argv, "--param", f"particle-filter.size={text}"]) == 0
    assert [dict(c.params["particle-filter"]) for c in ran] == [{"size": [8, 8]}] * 3


def _section(title: str) -> str:
    start = CLI_DOC.index(f"### {title}")
    end = CLI_DOC.find("\n## ", start)
    nxt = CLI_DOC.find("\n### ", start + 1)
    return CLI_DOC[start : min(e for e in (end, nxt) if e > 0)]


def test_the_worked_example_scores_an_outside_predictions_file(tmp_path, monkeypatch, capsys):
    section = _section("Worked example: score an outside predictions file")
    (python,) = re.findall(r"```python\n(.*?)```", section, re.S)
    (console,) = re.findall(r"```console\n(.*?)```", section, re.S)
    monkeypatch.chdir(tmp_path)
    exec(compile(python, "evaluate-cli.md worked example", "exec"), {})
    assert (tmp_path / "thumbs.csv").is_file()
    outputs: list[tuple[str, list[str]]] = []
    for line in console.splitlines():
        if line.startswith("$ "):
            outputs.append((line[2:].split("  #")[0], []))
        else:
            outputs[-1][1].append(" ".join(line.split()))
    assert [c.split()[1] for c, _ in outputs] == ["score", "show"]
    for command, shown in outputs:
        argv = shlex.split(command)
        assert argv[0] == "ppaloc"
        code = main(argv[1:])
        out, err = capsys.readouterr()
        assert code == 0, err
        printed = {" ".join(line.split()) for line in out.splitlines()}
        for line in shown:
            assert line in printed, (line, out)
    assert (tmp_path / "thumbs" / "report.html").is_file()
    assert (tmp_path / "thumbs.png").is_file()


def test_the_localise_csv_header_is_the_commands():
    from ppaloc.cli.localise import CSV_HEADER

    section = _section("The localise CSV")
    assert f"```text\n{CSV_HEADER}\n```" in section
    assert CSV_HEADER in (ROOT / "README.md").read_text()


def test_the_messages_shown_are_the_commands(gardens_point_dir, tmp_path, monkeypatch, capsys):
    """The two refusals the page shows, made again on Gardens Point."""
    section = _section("Predictions files")
    shown = re.findall(r"^ppaloc: error: .*$", section, re.M)
    assert len(shown) == 2
    monkeypatch.chdir(ROOT)  # the page's relative paths (../shared/data)
    spec = "gardens-point:../shared/data/gardens-point?ref=day_left&query=day_right"
    rows = [f"{i},{i},1" for i in range(200)]
    wrong = [*rows[:7], "7,250,1", *rows[8:]]  # line 9: the 8th row
    missing = rows[:17] + rows[18:]
    got = []
    for body in (wrong, missing):
        path = tmp_path / "netvlad.csv"
        path.write_text("query,reference,score\n" + "\n".join(body) + "\n")
        code = main(["score", str(path), "-d", spec, "--out", str(tmp_path / "o")])
        err = capsys.readouterr().err
        assert code == 1
        got.append(err.strip().replace(str(path), "netvlad.csv"))
    assert got == shown


def _accepted(argv: list[str], monkeypatch, capsys) -> None:
    """``ppaloc evaluate ARGV`` passes every check (the run itself replaced)."""
    import ppaloc.cli.commands as commands

    ran = []
    monkeypatch.setattr(commands, "run_evaluate", lambda config, *a, **k: ran.append(config))
    code = main(["evaluate", *argv])
    assert code == 0 and len(ran) == 1, capsys.readouterr().err


def test_the_config_examples_of_the_help_and_the_page_are_accepted(tmp_path, monkeypatch, capsys):
    # both set gamma, a parameter of the paper preset, on the robust weighted-node-lowres
    from click.testing import CliRunner

    from ppaloc.cli.main import cli

    text = CliRunner().invoke(cli, ["evaluate", "--help"], terminal_width=200).output
    example = text.split("run.toml:\n", 1)[1].split("\n\n", 1)[0]
    section = CLI_DOC.split("### Configuration files", 1)[1]
    page = re.search(r"```toml\n(.*?)```", section, re.S)[1]
    monkeypatch.chdir(tmp_path)
    for k, body in enumerate((example, page)):
        (tmp_path / f"{k}.toml").write_text("\n".join(line.strip() for line in body.split("\n")))
        _accepted(["--config", f"{k}.toml"], monkeypatch, capsys)


def test_the_param_examples_the_command_gives_are_accepted(monkeypatch, capsys):
    from click.testing import CliRunner

    from ppaloc.cli.main import cli

    text = CliRunner().invoke(cli, ["evaluate", "--help"], terminal_width=200).output
    (given,) = re.findall(r"e\.g\. ([\w-]+\.\w+=\w+)\.", " ".join(text.split()))
    assert main(["evaluate", "-d", "synthetic", "--param", "gain=8"]) == 1
    (hinted,) = re.findall(r"e\.g\. --param (\S+)\n", capsys.readouterr().err)
    for value in (given, hinted):
        method = value.split(".")[0]
        _accepted(
            ["-d", "synthetic:?places=6", "-m", method, "--param", value], monkeypatch, capsys
        )


@pytest.mark.parametrize("command", ["evaluate", "score", "sweep"])
def test_the_tolerance_help_gives_each_kinds_default(command):
    # it said "Accepted distance to the true frame, in frames." and no default, while
    # the run takes the dataset's own (Nordland 1, Gardens Point 2, a folder 0)
    from click.testing import CliRunner

    from ppaloc.cli.main import cli
    from ppaloc.datasets import load_dataset
    from ppaloc.datasets.loaders import folder, gardens_point, nordland

    text = CliRunner().invoke(cli, [command, "--help"], terminal_width=200).output
    text = " ".join(text.split("--tolerance", 1)[1].split("--recall")[0].split())
    synthetic = load_dataset("synthetic:?places=10").tolerance
    assert f"{nordland.DEFAULT_TOLERANCE} for nordland and synthetic" in text
    assert synthetic == nordland.DEFAULT_TOLERANCE
    assert f"{gardens_point.DEFAULT_TOLERANCE} for gardens-point" in text
    assert f"{folder.DEFAULT_TOLERANCE} for the other kinds" in text
