"""`identify` of the bundled examples against the JSON `mtcal identify --json` writes: the same
keys and texts, every number to 1e-12 relative; the physics search, an acceptance file and
what-if as the command line gives them."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

import mtcal
from conftest import EXAMPLES, assert_same_json, count_numbers, run_cli

CASES = {
    "five-axis": (EXAMPLES / "five-axis" / "session", []),
    "three-axis": (EXAMPLES / "three-axis" / "session", []),
    "five-axis+acceptance": (
        EXAMPLES / "five-axis" / "session",
        ["--acceptance", EXAMPLES / "acceptance" / "five-axis.toml"],
    ),
    "three-axis+acceptance": (
        EXAMPLES / "three-axis" / "session",
        ["--acceptance", EXAMPLES / "acceptance" / "three-axis.toml"],
    ),
    "five-axis+search": (EXAMPLES / "five-axis" / "session", ["--search"]),
    "five-axis-warm+search": (EXAMPLES / "five-axis-warm" / "session", ["--search"]),
}


def cli_json(mtcal_bin: Path, session: Path, extra: list, tmp_path: Path) -> dict:
    out = tmp_path / "cli.json"
    # Exit 1: done, but a check asked for failed or could not be decided (the acceptance).
    run_cli(mtcal_bin, "identify", session, "--quiet", "--json", out, *extra, ok=(0, 1))
    return json.loads(out.read_text())


def python_identify(session: Path, extra: list) -> mtcal.Identification:
    kwargs = {}
    if "--search" in extra:
        kwargs["search"] = True
    if "--acceptance" in extra:
        kwargs["acceptance"] = extra[extra.index("--acceptance") + 1]
    return mtcal.identify(session.relative_to(EXAMPLES.parent), **kwargs)


@pytest.mark.parametrize("case", list(CASES))
def test_identify_matches_the_cli_json(case, mtcal_bin, tmp_path, monkeypatch):
    session, extra = CASES[case]
    # Paths as the command line is given them (relative to the repository): the JSON names
    # the tolerance file as given.
    monkeypatch.chdir(EXAMPLES.parent)
    extra = [e.relative_to(EXAMPLES.parent) if isinstance(e, Path) else e for e in extra]
    cli = cli_json(mtcal_bin, session.relative_to(EXAMPLES.parent), extra, tmp_path)
    result = python_identify(session, extra)
    d = result.to_dict()
    assert count_numbers(cli) > 100
    assert_same_json(cli, d)
    # The objects mirror the JSON.
    assert result.schema == "mtcal.identify/1"
    assert [p.name for p in result.parameters] == [p["name"] for p in cli["parameters"]]
    for p, q in zip(result.parameters, cli["parameters"]):
        assert (p.value, p.u95, p.unit) == (q["value"], q["u95"], q["unit"])
        assert p.to_dict() == q
    assert [c.parameters for c in result.combinations] == [c["parameters"] for c in cli["unidentifiable"]]
    assert [v.name for v in result.validation] == [v["name"] for v in cli["validation"]]
    assert [x.to_dict() for x in result.discoveries] == cli["discoveries"]
    assert result.converged and result.verdict is None
    if "--acceptance" in extra:
        assert result.acceptance is not None
        assert result.acceptance.verdict == cli["acceptance"]["verdict"]
        assert result.acceptance.to_dict() == cli["acceptance"]
    else:
        assert result.acceptance is None and "acceptance" not in d
    if "--search" in extra:
        assert result.initial is not None and "parameters" in result.initial
    else:
        assert result.initial is None
    # The plain dicts are JSON again, and independent of the object.
    assert json.loads(json.dumps(d)) == d
    d["parameters"].clear()
    assert result.parameters and result.to_dict()["parameters"]


def test_the_search_reports_its_discoveries():
    result = mtcal.identify(EXAMPLES / "five-axis-warm" / "session", search=True)
    effects = {x.effect for x in result.discoveries}
    assert "reversal" in effects, effects
    backlash = next(x for x in result.discoveries if x.effect == "reversal")
    value = backlash.parameters[0]
    assert 2.5 < value["value"] < 3.7 and value["unit"] == "um"
    assert "physics search" in result.summary()


def test_the_summary_is_what_the_cli_prints(mtcal_bin, monkeypatch):
    monkeypatch.chdir(EXAMPLES.parent)
    session = "examples/three-axis/session"
    printed = run_cli(mtcal_bin, "identify", session, "--quiet").stdout
    summary = mtcal.identify(session).summary()
    # The command prints its header line, then the summary.
    assert printed.endswith(summary)
    assert printed[: -len(summary)].startswith("session examples/three-axis/session:")


def test_what_if_is_what_the_cli_prints(mtcal_bin, monkeypatch):
    monkeypatch.chdir(EXAMPLES.parent)
    session, other = "examples/five-axis/session", "examples/five-axis-warm/session"
    printed = run_cli(mtcal_bin, "identify", session, "--quiet", "--what-if", other).stdout
    table = printed[printed.index("with the runs of") :].splitlines()[1:]
    result = mtcal.identify(session, what_if=other)
    rows = result.what_if_rows
    assert rows is not None and len(rows) == len(table) >= 10
    for row, line in zip(rows, table):
        name, now, after, unit = re.match(r"\s+(.+?)\s+±(\S+)\s+→ ±(\S+)\s+(\S*)$", line).groups()
        assert row.name == name and row.unit == unit
        assert f"{row.now_u95:.4f}" == now and f"{row.after_u95:.4f}" == after
        assert row.after_u95 <= row.now_u95 + 1e-12
    assert result.what_if(other) == rows


def test_the_suggested_model_and_the_report():
    result = mtcal.identify(EXAMPLES / "three-axis" / "session")
    assert "mtcal.errors/1" in result.suggested_model()
    page = result.report_page()
    assert page.startswith("<!DOCTYPE html>") or page.lstrip().lower().startswith("<!doctype html>")


def test_a_broken_tolerance_file_is_located(tmp_path):
    bad = tmp_path / "tol.toml"
    lines = (EXAMPLES / "acceptance" / "five-axis.toml").read_text().splitlines()
    at = next(i for i, l in enumerate(lines) if l.startswith("schema")) + 1
    lines.insert(at, "bogus = 1")
    bad.write_text("\n".join(lines) + "\n")
    with pytest.raises(mtcal.IdentifyError) as e:
        mtcal.identify(EXAMPLES / "five-axis" / "session", acceptance=bad)
    assert (e.value.file, e.value.line, e.value.column) == (str(bad), at + 1, 1), str(e.value)


def test_a_fit_stopped_early_says_so_as_the_cli(mtcal_bin, tmp_path, monkeypatch):
    monkeypatch.chdir(EXAMPLES.parent)
    session = "examples/three-axis/session"
    out = tmp_path / "cli.json"
    # Exit 1 (done, but the fit did not converge); the exit codes are tested in xtask/tests.
    run_cli(mtcal_bin, "identify", session, "--quiet", "--max-iterations", "1", "--json", out, ok=(0, 1))
    result = mtcal.identify(session, max_iterations=1)
    assert not result.converged
    assert result.verdict is not None and result.verdict.startswith("NOT CONVERGED")
    assert_same_json(json.loads(out.read_text()), result.to_dict())
