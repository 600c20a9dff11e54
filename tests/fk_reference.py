#!/usr/bin/env python3
"""Reference forward kinematics of a URDF machine with pinocchio, for tests/fk_reference.rs.

Usage: python3 tests/fk_reference.py MACHINE.urdf POSITIONS

POSITIONS is a JSON list of objects mapping joint names (axis letters) to positions in URDF
units (m, rad), e.g. '[{"X": 0.1, "C": 1.2}]', or "-" to read that JSON from stdin. Joints
missing from an object stay at zero.

Prints one JSON object: {"poses": [{"tool": T, "workpiece": T}, ...]}, where each T is the 4x4
homogeneous placement of that link's frame in the root link's frame (row-major nested lists).

Exit codes: 0 on success, 2 on bad input, 3 if pinocchio cannot be imported (the Rust test
then skips, or fails under CI).
"""

import json
import math
import sys


def set_joint(model, q, name, value):
    """Writes one joint position into pinocchio's configuration vector.

    Unbounded revolute joints (URDF `continuous`) have two configuration entries in pinocchio,
    (cos, sin) of the angle; every other joint mtcal uses has one.
    """
    if not model.existJointName(name):
        raise KeyError(f"the model has no joint named {name!r}")
    joint = model.joints[model.getJointId(name)]
    if joint.nq == 1:
        q[joint.idx_q] = value
    elif joint.nq == 2:
        q[joint.idx_q] = math.cos(value)
        q[joint.idx_q + 1] = math.sin(value)
    else:
        raise ValueError(f"joint {name!r} has nq = {joint.nq}; expected 1 or 2")


def main(argv):
    if len(argv) != 3:
        print(__doc__, file=sys.stderr)
        return 2
    try:
        import pinocchio as pin
    except ImportError as e:
        print(f"pinocchio is not installed ({e}); pip install pin", file=sys.stderr)
        return 3
    text = sys.stdin.read() if argv[2] == "-" else argv[2]
    positions = json.loads(text)
    model = pin.buildModelFromUrdf(argv[1])
    data = model.createData()
    frames = {
        name: model.getFrameId(name, pin.FrameType.BODY) for name in ("tool", "workpiece")
    }
    poses = []
    for sample in positions:
        q = pin.neutral(model)
        for name, value in sample.items():
            set_joint(model, q, name, float(value))
        pin.framesForwardKinematics(model, data, q)
        poses.append(
            {name: data.oMf[fid].homogeneous.tolist() for name, fid in frames.items()}
        )
    json.dump({"poses": poses}, sys.stdout)
    print()
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv))
    except (KeyError, ValueError, json.JSONDecodeError) as e:
        print(f"fk_reference.py: {e}", file=sys.stderr)
        sys.exit(2)
