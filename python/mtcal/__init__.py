"""mtcal from Python: machine-tool metrology on mtcal's Rust core.

Load a machine (URDF or topology code) and evaluate its poses and pose errors for arrays of
axis positions; read a session folder or build one from numpy arrays; identify it (the fit or
the physics search, an acceptance file, what another session would add) into an
:class:`Identification` that mirrors the JSON ``mtcal identify --json`` writes; simulate a test
plan. Every number comes from the same library calls as the ``mtcal`` command line.

Units: positions and pose errors in SI (m, rad) as mtcal's Rust API; run tables of sessions in
file units (mm, degrees, µm, µrad) as the run files hold them; identified values in the units
the JSON names (``unit``).

Errors are :class:`MtcalError` (subclasses :class:`MachineError`, :class:`SessionError`,
:class:`IdentifyError`, :class:`SimulateError`) with ``file``, ``line`` and ``column`` where the
input is wrong (``None`` when the error has no place).
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from typing import Any, Dict, Iterator, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _mtcal
from ._mtcal import (
    IdentifyError,
    MachineError,
    MtcalError,
    SessionError,
    SimulateError,
)

__version__: str = _mtcal.__version__

__all__ = [
    "Machine",
    "Session",
    "Run",
    "identify",
    "simulate",
    "Identification",
    "Parameter",
    "Combination",
    "Discovery",
    "ValidationRun",
    "Acceptance",
    "WhatIfRow",
    "MtcalError",
    "MachineError",
    "SessionError",
    "IdentifyError",
    "SimulateError",
]

PathLike = Union[str, "os.PathLike[str]"]


def _rows(q: Any, n_axes: int) -> Tuple[np.ndarray, bool]:
    """Positions as a C-contiguous (N, n_axes) float64 array; whether one row was given."""
    a = np.ascontiguousarray(q, dtype=np.float64)
    if a.ndim == 1:
        return a.reshape(1, -1), True
    if a.ndim != 2:
        raise ValueError(f"axis positions: expected shape (N, {n_axes}) or ({n_axes},), found {a.shape}")
    return a, False


class Machine:
    """A machine and its error model: a URDF path (with its ``<stem>.errors.toml`` if there is
    one, else the full ISO 230-1 model) or a topology code such as ``CAFYXZ`` or ``ZFYX``
    (``reading="workpiece"``, the default, reads the first letters as the workpiece branch;
    ``"tool"`` as the tool branch).

    Positions are rows of axis values in :attr:`axes` order, SI (m, rad); one row (shape
    ``(k,)``) gives one result, ``(N, k)`` gives ``N``: the loop runs in Rust.
    """

    def __init__(self, machine: PathLike, reading: str = "workpiece") -> None:
        self._arg = os.fspath(machine)
        self._rs = _mtcal.RsMachine(self._arg, reading)

    @classmethod
    def _wrap(cls, rs: "_mtcal.RsMachine", arg: str) -> "Machine":
        m = cls.__new__(cls)
        m._arg = arg
        m._rs = rs
        return m

    @property
    def name(self) -> str:
        return self._rs.name

    @property
    def axes(self) -> str:
        """Axis letters in canonical order (X Y Z U V W A B C): the columns of positions."""
        return self._rs.axes

    @property
    def n_axes(self) -> int:
        return len(self._rs.axes)

    @property
    def source(self) -> str:
        return self._rs.source

    @property
    def model_source(self) -> str:
        return self._rs.model_source

    @property
    def topology_code(self) -> str:
        return self._rs.topology_code

    @property
    def limits(self) -> List[Optional[Tuple[float, float]]]:
        """Each axis' limits ``(low, high)`` in m or rad; ``None`` where it has none."""
        return self._rs.limits

    @property
    def parameters(self) -> List[str]:
        """The ISO 230-1 names of the error model's parameters."""
        return self._rs.parameters

    @property
    def coefficient_labels(self) -> List[str]:
        """One label per coefficient (``EXX.P2`` for a component error's second)."""
        return self._rs.coefficient_labels

    @property
    def n_coeffs(self) -> int:
        return self._rs.n_coeffs

    def zeros(self) -> np.ndarray:
        """A coefficient vector of the nominal machine (every error zero)."""
        return np.zeros(self.n_coeffs)

    def read_params(self, path: PathLike) -> np.ndarray:
        """A parameter file (``mtcal.params/1``, or an identify JSON) as coefficients (SI)."""
        return self._rs.read_params(os.fspath(path))

    def params_text(self, coeffs: Any) -> str:
        """Coefficients as the text of a parameter file (file units)."""
        return self._rs.params_text(self._coeffs(coeffs))

    def coefficients(self, values: Mapping[str, float]) -> np.ndarray:
        """A coefficient vector (SI) from ``{label: value}`` by :attr:`coefficient_labels`;
        the rest zero."""
        labels = self.coefficient_labels
        out = np.zeros(len(labels))
        for name, value in values.items():
            try:
                out[labels.index(name)] = value
            except ValueError:
                raise MachineError(f"coefficient `{name}` is not in the error model") from None
        return out

    def _coeffs(self, coeffs: Any) -> np.ndarray:
        if coeffs is None:
            return self.zeros()
        return np.ascontiguousarray(coeffs, dtype=np.float64).reshape(-1)

    def nominal_pose(self, q: Any) -> np.ndarray:
        """Nominal tool poses in the workpiece frame as 4 × 4 matrices: ``(N, 4, 4)``."""
        rows, one = _rows(q, self.n_axes)
        out = self._rs.nominal_pose(rows)
        return out[0] if one else out

    def pose(self, q: Any, coeffs: Any = None) -> np.ndarray:
        """Actual tool poses in the workpiece frame with the errors ``coeffs``: ``(N, 4, 4)``."""
        rows, one = _rows(q, self.n_axes)
        out = self._rs.pose(rows, self._coeffs(coeffs))
        return out[0] if one else out

    def pose_error(self, q: Any, coeffs: Any = None, first_order: bool = False) -> np.ndarray:
        """Pose errors ``(N, 6)``: ``[dx, dy, dz, ea, eb, ec]`` (m, rad) in the workpiece frame,
        exact or to first order."""
        rows, one = _rows(q, self.n_axes)
        out = self._rs.pose_error(rows, self._coeffs(coeffs), first_order)
        return out[0] if one else out

    def __repr__(self) -> str:
        return repr(self._rs)


@dataclass
class Run:
    """One run of a session built in memory: what its CSV file would hold, in file units.

    ``positions`` is ``(N, len(axes))`` (mm, degrees), ``values`` ``(N, len(readings))`` (the
    instrument's units; ``None`` for a validation run without readings), ``context`` the
    ``T_<name>``, ``P_<name>``, ``H_<name>``, ``S``, ``F`` columns, ``labels`` text columns.
    ``setup`` names a shared set-up of the session or is the run's own table.
    """

    name: str
    instrument: str
    t: Any
    axes: str
    positions: Any
    readings: Sequence[str] = ()
    values: Any = None
    setup: Union[str, Mapping[str, Any], None] = None
    use: str = "fit"
    context: Mapping[str, Any] = field(default_factory=dict)
    labels: Mapping[str, Sequence[str]] = field(default_factory=dict)
    file: Optional[str] = None
    extra: Mapping[str, Any] = field(default_factory=dict)
    columns: Optional[Sequence[str]] = None

    def _arg(self) -> Dict[str, Any]:
        t = np.ascontiguousarray(self.t, dtype=np.float64).reshape(-1)
        positions = np.ascontiguousarray(self.positions, dtype=np.float64)
        if positions.ndim == 1:
            positions = positions.reshape(-1, 1)
        values = None
        if self.values is not None:
            values = np.ascontiguousarray(self.values, dtype=np.float64)
            if values.ndim == 1:
                values = values.reshape(-1, 1)
        context = [(k, np.ascontiguousarray(v, dtype=np.float64).reshape(-1)) for k, v in self.context.items()]
        labels = [(k, [str(x) for x in v]) for k, v in self.labels.items()]
        columns = list(self.columns) if self.columns is not None else []
        if not columns:
            columns = ["t", *self.axes, *self.labels.keys()]
            if values is not None:
                columns += list(self.readings)
            columns += list(self.context.keys())
        setup = self.setup if self.setup is not None else {}
        return {
            "name": self.name,
            "instrument": self.instrument,
            "file": self.file or f"{self.name}.csv",
            "use": self.use,
            "setup": json.dumps(setup),
            "extra": json.dumps(dict(self.extra)),
            "columns": columns,
            "t": t,
            "axes": self.axes,
            "positions": positions,
            "readings": list(self.readings),
            "values": values,
            "context": context,
            "labels": labels,
        }


class Session:
    """A measurement session: a folder (:meth:`load`) or runs held in memory
    (:meth:`from_arrays`, :func:`simulate`). Identify it with :func:`identify`."""

    def __init__(self, path: PathLike) -> None:
        self._rs = _mtcal.RsSession.load(os.fspath(path))

    @classmethod
    def load(cls, path: PathLike) -> "Session":
        """A session folder (or its ``session.toml``), read and checked."""
        return cls(path)

    @classmethod
    def _wrap(cls, rs: "_mtcal.RsSession") -> "Session":
        s = cls.__new__(cls)
        s._rs = rs
        return s

    @classmethod
    def from_arrays(
        cls,
        machine: Union[PathLike, Machine],
        runs: Sequence[Run],
        setups: Optional[Mapping[str, Mapping[str, Any]]] = None,
        identify: Optional[Mapping[str, Any]] = None,
        dir: PathLike = ".",
    ) -> "Session":
        """A session from numpy arrays, without files: ``machine`` a URDF path (relative to
        ``dir``) or a topology code, ``setups`` the ``[setup.<name>]`` tables, ``identify`` the
        ``[identify]`` table, one :class:`Run` per ``[[run]]``. The same tables as a folder's
        give the same identification. ``dir`` is the folder its files would be in (messages
        name them there)."""
        arg = machine._arg if isinstance(machine, Machine) else os.fspath(machine)
        rs = _mtcal.RsSession.from_parts(
            os.fspath(dir),
            arg,
            json.dumps(dict(setups or {})),
            json.dumps(dict(identify or {})),
            [r._arg() for r in runs],
        )
        return cls._wrap(rs)

    @property
    def dir(self) -> str:
        return os.fspath(self._rs.dir)

    @property
    def in_memory(self) -> bool:
        return self._rs.in_memory

    @property
    def runs(self) -> List[Tuple[str, str, str, int]]:
        """``(name, instrument, use, samples)`` of every run, in the manifest's order."""
        return self._rs.runs

    @property
    def machine_source(self) -> str:
        return self._rs.machine_source

    def machine(self) -> Machine:
        """The session's machine with its error model."""
        return Machine._wrap(self._rs.machine(), self.machine_source)

    def __repr__(self) -> str:
        return repr(self._rs)


class _Record:
    """A JSON object with attribute access; :meth:`to_dict` gives it back as plain data."""

    _data: Dict[str, Any]

    def __init__(self, data: Mapping[str, Any]) -> None:
        object.__setattr__(self, "_data", dict(data))

    def __getattr__(self, name: str) -> Any:
        try:
            return self._data[name]
        except KeyError:
            raise AttributeError(f"{type(self).__name__} has no field `{name}`") from None

    def __getitem__(self, name: str) -> Any:
        return self._data[name]

    def keys(self) -> Iterator[str]:
        return iter(self._data.keys())

    def get(self, name: str, default: Any = None) -> Any:
        return self._data.get(name, default)

    def to_dict(self) -> Dict[str, Any]:
        return json.loads(json.dumps(self._data))

    def __eq__(self, other: object) -> bool:
        return type(self) is type(other) and self._data == other._data  # type: ignore[attr-defined]

    def __repr__(self) -> str:
        head = ", ".join(f"{k}={self._data[k]!r}" for k in list(self._data)[:4])
        return f"{type(self).__name__}({head}{', …' if len(self._data) > 4 else ''})"


class Parameter(_Record):
    """An identified parameter: ``name``, ``value`` ± ``u95`` (95 %) in ``unit``, ``kind``."""

    name: str
    value: float
    unit: str
    u95: float
    kind: str


class Combination(_Record):
    """Parameters the data cannot separate (``parameters``) and ``why``."""

    parameters: List[str]
    why: str


class Discovery(_Record):
    """An effect the physics search added (``effect``, ``label``, ``parameters``, RMS before
    and after, ``corrected``: the machine parameters it had biased)."""

    effect: str
    label: str


class ValidationRun(_Record):
    """A validation run predicted: ``name``, ``instrument``, ``rms_um``, ``channels``,
    ``metrics``."""

    name: str
    rms_um: float


class Acceptance(_Record):
    """The verdicts against a tolerance file: ``verdict`` (``"pass"``, ``"fail"``, ``"cannot
    decide"``) and ``checks``."""

    verdict: str
    checks: List[Dict[str, Any]]


@dataclass(frozen=True)
class WhatIfRow:
    """One parameter's 95 % interval now and with another session's runs added."""

    name: str
    now_u95: float
    after_u95: float
    unit: str


class Identification:
    """The result of :func:`identify`: the JSON ``mtcal identify --json`` writes
    (``mtcal.identify/1``, docs/FORMATS.md) as Python objects. :meth:`to_dict` is that JSON as
    plain data; the attributes are its main parts."""

    def __init__(self, outcome: "_mtcal.RsOutcome") -> None:
        self._outcome = outcome
        self._json = outcome.json()
        self._data: Dict[str, Any] = json.loads(self._json)
        d = self._data
        self.schema: str = d["schema"]
        self.parameters: List[Parameter] = [Parameter(p) for p in d.get("parameters", [])]
        self.combinations: List[Combination] = [Combination(c) for c in d.get("unidentifiable", [])]
        self.weakly_determined: List[Combination] = [Combination(c) for c in d.get("weakly_determined", [])]
        self.discoveries: List[Discovery] = [Discovery(x) for x in d.get("discoveries", [])]
        self.validation: List[ValidationRun] = [ValidationRun(v) for v in d.get("validation", [])]
        self.fit: Dict[str, Any] = d.get("fit", {})
        self.solver: Dict[str, Any] = d.get("solver", {})
        self.acceptance: Optional[Acceptance] = Acceptance(d["acceptance"]) if "acceptance" in d else None
        #: What a person reads first when the fit did not converge or the model does not
        #: explain the recordings; ``None`` when both hold (as ``mtcal identify`` prints it).
        self.verdict: Optional[str] = outcome.verdict()
        initial = outcome.initial_json()
        #: The fit before the physics search (its JSON as plain data); ``None`` without it.
        self.initial: Optional[Dict[str, Any]] = json.loads(initial) if initial is not None else None
        #: Rows of :meth:`what_if` when ``identify(what_if=…)`` asked for them.
        self.what_if_rows: Optional[List[WhatIfRow]] = None

    @property
    def converged(self) -> bool:
        return bool(self.solver.get("converged", False))

    def parameter(self, name: str) -> Parameter:
        """The identified parameter called ``name``."""
        for p in self.parameters:
            if p.name == name:
                return p
        raise KeyError(name)

    def values(self) -> Dict[str, float]:
        """``{name: value}`` of every identified parameter (in its unit)."""
        return {p.name: p.value for p in self.parameters}

    def to_dict(self) -> Dict[str, Any]:
        """The JSON ``mtcal identify --json`` writes, as plain dicts and lists."""
        return json.loads(self._json)

    def to_json(self) -> str:
        """The JSON text exactly as ``mtcal identify --json`` writes it."""
        return self._json

    def summary(self, verbose: bool = False) -> str:
        """What ``mtcal identify`` prints after its header."""
        return self._outcome.screen(verbose)

    def what_if(self, session: PathLike) -> List[WhatIfRow]:
        """What adding the runs of another session folder would do to every interval,
        without refitting."""
        rows, _text = self._outcome.what_if(os.fspath(session))
        return [WhatIfRow(*r) for r in rows]

    def suggested_model(self) -> str:
        """The error model these runs identify, as an ``.errors.toml``."""
        return self._outcome.suggested_model()

    def report_page(self) -> str:
        """The HTML report (``index.html``, self-contained)."""
        return self._outcome.report_page()

    def __repr__(self) -> str:
        return (
            f"Identification({len(self.parameters)} parameters, {len(self.combinations)} "
            f"combinations, {len(self.discoveries)} discoveries, fit rms "
            f"{self.fit.get('rms_um', float('nan')):.3f} um{', ' + self.verdict.splitlines()[0] if self.verdict else ''})"
        )


def identify(
    session: Union[Session, PathLike],
    *,
    search: bool = False,
    acceptance: Optional[PathLike] = None,
    what_if: Optional[PathLike] = None,
    threads: int = 0,
    max_iterations: Optional[int] = None,
) -> Identification:
    """Identifies a session as ``mtcal identify`` does: the fit (or with ``search=True`` the
    physics search), prediction bands, the information account; ``acceptance`` a tolerance
    file (``mtcal.acceptance/1``) judged on the result; ``what_if`` another session folder
    whose runs' effect on every interval fills :attr:`Identification.what_if_rows`."""
    if not isinstance(session, Session):
        session = Session.load(session)
    outcome = _mtcal.identify(
        session._rs,
        search=search,
        acceptance=os.fspath(acceptance) if acceptance is not None else None,
        threads=threads,
        max_iterations=max_iterations,
    )
    result = Identification(outcome)
    if what_if is not None:
        result.what_if_rows = result.what_if(what_if)
    return result


def simulate(
    plan: PathLike,
    out: Optional[PathLike] = None,
    *,
    dir: Optional[PathLike] = None,
) -> Session:
    """Simulates a test plan (``plan.toml``, crates/simulate): with ``out``, writes the session
    folder as ``mtcal simulate PLAN --out OUT`` does and returns it loaded; without, returns the
    session held in memory (``dir``: the folder its tables name, default
    ``<plan folder>/simulated-session``)."""
    rs = _mtcal.simulate(
        os.fspath(plan),
        out=os.fspath(out) if out is not None else None,
        dir=os.fspath(dir) if dir is not None else None,
    )
    return Session._wrap(rs)
