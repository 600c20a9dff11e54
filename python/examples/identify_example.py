"""Identify the bundled five-axis example from Python, and use the result.

    python3 -m pip install ./python
    python3 python/examples/identify_example.py
"""

from pathlib import Path

import numpy as np

import mtcal

repo = Path(__file__).resolve().parents[2]
session = repo / "examples" / "five-axis" / "session"

# The identification `mtcal identify` runs; the JSON it writes, as Python objects.
result = mtcal.identify(session, acceptance=repo / "examples" / "acceptance" / "five-axis.toml")
print(result)
for p in result.parameters:
    if p.kind == "machine":
        print(f"  {p.name:8} {p.value:9.3f} ± {p.u95:.3f} {p.unit}")
for c in result.combinations:
    print("  cannot separate:", ", ".join(c.parameters))
print("acceptance:", result.acceptance.verdict if result.acceptance else "none asked")

# The machine of the session with the identified errors: pose errors (m, rad) of 1000 poses
# in one call.
machine = mtcal.Machine(session / "machine.urdf")
coeffs = machine.coefficients(
    {p.name: p.value * 1e-6 for p in result.parameters if p.kind == "machine"}
)
rng = np.random.default_rng(0)
limits = [lim or (-np.pi, np.pi) for lim in machine.limits]  # C turns without limits
q = np.column_stack([rng.uniform(lo, hi, 1000) for lo, hi in limits])
errors = machine.pose_error(q, coeffs)
print(f"largest tool-point error over 1000 poses: {1e6 * np.abs(errors[:, :3]).max():.2f} um")
assert result.to_dict()["schema"] == "mtcal.identify/1"
