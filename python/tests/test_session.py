"""Sessions: a folder and its twin built from numpy arrays in memory give the same
identification; `simulate` in memory and into a folder as `mtcal simulate` does; a broken
session raises an error carrying its file, line and column."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

import mtcal
from conftest import EXAMPLES, REPO, assert_same_json, run_cli

try:  # Python 3.11+
    import tomllib
except ImportError:  # pragma: no cover - older Pythons
    tomllib = None  # type: ignore[assignment]

CONTEXT_PREFIXES = ("T_", "P_", "H_")


def read_csv(path: Path):
    """A run file read by numpy: its header and its columns."""
    header = path.read_text().splitlines()[0].split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return [h.strip() for h in header], data


def twin(folder: Path) -> mtcal.Session:
    """The session of `folder` built from numpy arrays: the manifest read by tomllib, each run
    file by numpy."""
    if tomllib is None:
        pytest.skip("tomllib needs Python 3.11")
    manifest = tomllib.loads((folder / "session.toml").read_text())
    machine = mtcal.Machine(folder / manifest["machine"]) if (folder / manifest["machine"]).is_file() else None
    letters = machine.axes if machine else mtcal.Machine(manifest["machine"]).axes
    runs = []
    for r in manifest["run"]:
        header, data = read_csv(folder / r["file"])
        col = {h: data[:, i] for i, h in enumerate(header)}
        axes = "".join(h for h in header if len(h) == 1 and h in letters)
        context = {h: col[h] for h in header if h.startswith(CONTEXT_PREFIXES) or h in ("S", "F")}
        readings = [h for h in header if h != "t" and h not in axes and h not in context]
        extra = {k: v for k, v in r.items() if k not in ("name", "instrument", "file", "use", "setup")}
        runs.append(
            mtcal.Run(
                name=r["name"],
                instrument=r["instrument"],
                file=r["file"],
                use=r.get("use", "fit"),
                setup=r.get("setup", {}),
                t=col["t"],
                axes=axes,
                positions=np.column_stack([col[a] for a in axes]),
                readings=readings,
                values=np.column_stack([col[h] for h in readings]) if readings else None,
                context=context,
                extra=extra,
                columns=header,
            )
        )
    return mtcal.Session.from_arrays(
        manifest["machine"],
        runs,
        setups=manifest.get("setup", {}),
        identify=manifest.get("identify", {}),
        dir=folder,
    )


@pytest.mark.parametrize(
    "folder,options",
    [
        ("five-axis/session", {}),
        ("three-axis/session", {"acceptance": EXAMPLES / "acceptance" / "three-axis.toml"}),
        ("five-axis-warm/session", {"search": True}),
    ],
)
def test_a_session_built_in_memory_identifies_as_its_folder(folder, options):
    folder = EXAMPLES / folder
    memory = twin(folder)
    loaded = mtcal.Session.load(folder)
    assert memory.in_memory and not loaded.in_memory
    assert memory.runs == loaded.runs
    assert memory.machine_source == loaded.machine_source
    a = mtcal.identify(memory, **options)
    b = mtcal.identify(loaded, **options)
    # Identical, not merely close: the same tables give the same study.
    assert a.to_json() == b.to_json()
    assert a.verdict == b.verdict
    assert a.summary(verbose=True) == b.summary(verbose=True)
    assert a.initial == b.initial
    if options.get("search"):
        assert a.discoveries, "the search finds the planted effects in memory as from the folder"


def test_an_in_memory_run_is_checked_and_located():
    folder = EXAMPLES / "five-axis" / "session"
    good = twin(folder)
    assert good.runs[0][3] > 10
    run = mtcal.Run(
        name="r",
        instrument="rtest",
        setup="ball-low",
        t=[0.0, 1.0, 0.5],  # not increasing
        axes="XYZAC",
        positions=np.zeros((3, 5)),
        readings=["dx", "dy", "dz"],
        values=np.zeros((3, 3)),
    )
    manifest = tomllib.loads((folder / "session.toml").read_text()) if tomllib else pytest.skip("tomllib")
    with pytest.raises(mtcal.SessionError) as e:
        mtcal.Session.from_arrays("machine.urdf", [run], setups=manifest["setup"], dir=folder)
    assert e.value.file == str(folder / "r.csv"), str(e.value)
    with pytest.raises(mtcal.SessionError, match="expected 5 columns"):
        mtcal.Session.from_arrays(
            "machine.urdf",
            [mtcal.Run(name="r", instrument="rtest", setup="ball-low", t=[0.0], axes="XYZAC",
                       positions=np.zeros((1, 4)), readings=["dx", "dy", "dz"], values=np.zeros((1, 3)))],
            setups=manifest["setup"],
            dir=folder,
        )


def test_simulate_in_memory_and_into_a_folder_as_the_cli(mtcal_bin, tmp_path, monkeypatch):
    plan = EXAMPLES / "five-axis" / "plan.toml"
    cli_dir = tmp_path / "cli"
    run_cli(mtcal_bin, "simulate", plan, "--out", cli_dir)
    # Into a folder: the same files, byte for byte.
    py_dir = tmp_path / "py"
    written = mtcal.simulate(plan, py_dir)
    assert not written.in_memory and Path(written.dir) == py_dir
    cli_files = sorted(p.relative_to(cli_dir) for p in cli_dir.rglob("*") if p.is_file())
    py_files = sorted(p.relative_to(py_dir) for p in py_dir.rglob("*") if p.is_file())
    assert cli_files == py_files and len(cli_files) > 10
    for f in cli_files:
        assert (cli_dir / f).read_bytes() == (py_dir / f).read_bytes(), f
    # In memory: the identification of the folder the command line wrote.
    memory = mtcal.simulate(plan, dir=tmp_path / "mem")
    assert memory.in_memory
    assert [r[:3] for r in memory.runs] == [r[:3] for r in written.runs]
    out = tmp_path / "cli.json"
    run_cli(mtcal_bin, "identify", cli_dir, "--quiet", "--json", out, ok=(0, 1))
    assert_same_json(json.loads(out.read_text()), mtcal.identify(memory).to_dict())


def test_a_broken_plan_is_located(tmp_path):
    plan = tmp_path / "plan.toml"
    plan.write_text('machine = "CAFYXZ"\nseed = [1\n')
    with pytest.raises(mtcal.SimulateError) as e:
        mtcal.simulate(plan)
    assert e.value.file == str(plan), str(e.value)


def broken_copy(tmp_path: Path, old: str, new: str) -> Path:
    folder = tmp_path / "session"
    shutil.copytree(EXAMPLES / "five-axis" / "session", folder)
    manifest = folder / "session.toml"
    text = manifest.read_text()
    assert old in text
    manifest.write_text(text.replace(old, new, 1))
    return folder


def place(text: str, needle: str):
    """1-based line and column of the first `needle` in `text`."""
    before = text[: text.index(needle)]
    return before.count("\n") + 1, len(before) - (before.rfind("\n") + 1) + 1


def test_a_broken_session_toml_raises_an_error_with_its_place(tmp_path, mtcal_bin):
    folder = broken_copy(tmp_path, 'use = "fit"', 'use = "fti"')
    manifest = folder / "session.toml"
    line, column = place(manifest.read_text(), '"fti"')
    for call in (mtcal.Session.load, mtcal.identify):
        with pytest.raises(mtcal.SessionError) as e:
            call(folder)
        assert isinstance(e.value, mtcal.MtcalError)
        assert (e.value.file, e.value.line, e.value.column) == (str(manifest), line, column), str(e.value)
        assert e.value.message == str(e.value)
    # The command line says the same place.
    done = run_cli(mtcal_bin, "identify", folder, "--quiet", ok=(2,))
    assert f"{manifest}:{line}:{column}:" in done.stderr


def test_an_unknown_key_and_a_missing_run_file_are_located(tmp_path):
    folder = broken_copy(tmp_path, "[setup.bar]", "[setup.bar]\nbogus_key = 1")
    with pytest.raises(mtcal.MtcalError) as e:
        mtcal.identify(folder)
    manifest = folder / "session.toml"
    assert e.value.file == str(manifest), str(e.value)
    assert e.value.line == place(manifest.read_text(), "bogus_key")[0], str(e.value)
    assert e.value.column is not None

    folder = tmp_path / "s2"
    shutil.copytree(EXAMPLES / "five-axis" / "session", folder)
    (folder / "rtest-yza.csv").unlink()
    with pytest.raises(mtcal.SessionError) as e:
        mtcal.Session.load(folder)
    text = (folder / "session.toml").read_text()
    assert (e.value.file, e.value.line) == (str(folder / "session.toml"), place(text, '"rtest-yza.csv"')[0])


def test_a_broken_run_file_is_located(tmp_path):
    folder = tmp_path / "session"
    shutil.copytree(EXAMPLES / "five-axis" / "session", folder)
    run = folder / "rtest-xyc-a0.csv"
    lines = run.read_text().splitlines()
    cells = lines[3].split(",")
    cells[6] = "abc"
    lines[3] = ",".join(cells)
    run.write_text("\n".join(lines) + "\n")
    with pytest.raises(mtcal.SessionError) as e:
        mtcal.identify(folder)
    assert (e.value.file, e.value.line, e.value.column) == (str(run), 4, 7), str(e.value)


def test_a_session_without_its_folder_raises_with_the_path(tmp_path):
    with pytest.raises(mtcal.SessionError) as e:
        mtcal.Session.load(tmp_path / "none")
    assert e.value.file is not None and str(tmp_path / "none") in e.value.file
