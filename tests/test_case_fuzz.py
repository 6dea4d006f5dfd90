"""Property-based: malformed case files never give a traceback. Every mutation of a valid
case file either still parses into a valid case, or raises CaseError whose problems each
name a key, and the command line then exits with code 2 and one line per problem, before
any solve."""

from __future__ import annotations

import contextlib
import io
import math
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cablefem.app.cli import main
from cablefem.case import Case, CaseError, load_case

pytestmark = pytest.mark.single_rank  # parsing, no dolfinx: nothing distributed

BASE = """title = "fuzz"
[section]
EA = 17857.14
EI = 4.0e-4
GJ = 3.0e-4
mass = 1.0
diameter = 0.01
[gravity]
g = 1.0
direction = [0, 0, -1]
[geometry]
length = 1.0
[mesh]
elements = 10
grading = 1.0
[[anchors]]
name = "p"
position = [0, 0, 0]
type = "clamped"
direction = [1, 0, 0]
[[anchors]]
name = "q"
position = [1.0013333, 0, 0]
type = "pinned"
[anchors.motion]
type = "ellipse"
omega = 9.9
axis_sin = [0, 0, 1e-3]
axis_cos = [0, 5e-4, 0]
[[point_masses]]
s = 0.5
mass = 0.1
[damping]
ratio = 0.005
frequencies = [16.4, 32.8]
[dynamics]
t_end = 1.0
dt = 0.01
rho_inf = 0.9
[modal]
modes = 3
[solver]
tension_only = true
""".splitlines()


def toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, int):
        return str(v)
    if isinstance(v, str):
        return '"' + v.replace("\\\\", "").replace('"', "").replace("\n", " ") + '"'
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    return "{}"


scalars = st.one_of(st.booleans(), st.integers(-10**6, 10**6),
                    st.floats(allow_nan=True, allow_infinity=True),
                    st.text(alphabet="abcxyz_ -.,0123", max_size=8))
values = st.one_of(scalars, st.lists(scalars, max_size=5), st.just({}))
mutation = st.one_of(
    st.tuples(st.just("value"), st.integers(0, len(BASE) - 1), values),
    st.tuples(st.just("drop"), st.integers(0, len(BASE) - 1), st.none()),
    st.tuples(st.just("typo"), st.integers(0, len(BASE) - 1), st.integers(0, 5)),
    st.tuples(st.just("junk"), st.integers(0, len(BASE) - 1),
              st.text(alphabet='abc=[]"{}. 012\n', max_size=12)))


def mutate(lines: list[str], muts) -> str:
    out = list(lines)
    for kind, i, arg in muts:
        i = i % len(out)
        if kind == "value" and "=" in out[i]:
            out[i] = out[i].split("=")[0] + "= " + toml_value(arg)
        elif kind == "drop":
            out.pop(i)
        elif kind == "typo" and "=" in out[i]:
            key = out[i].split("=")[0].strip()
            j = arg % max(len(key), 1)
            out[i] = key[:j] + key[j + 1:] + "x =" + out[i].split("=", 1)[1]
        elif kind == "junk":
            out.insert(i, arg)
    return "\n".join(out) + "\n"


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(mutation, min_size=1, max_size=3))
def test_malformed_case_files_never_traceback(muts):
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "case.toml"
        path.write_text(mutate(BASE, muts))
        try:
            case = load_case(path)
        except CaseError as err:
            assert err.problems and all(key and msg for key, msg in err.problems)
            lines = str(err).strip().splitlines()
            assert len(lines) == len(err.problems)
            stderr = io.StringIO()
            with contextlib.redirect_stderr(stderr):
                code = main(["run", str(path), "--output", str(Path(tmp) / "out")])
            assert code == 2
            text = stderr.getvalue()
            assert "Traceback" not in text and err.problems[0][0] in text
            assert not (Path(tmp) / "out").exists()  # rejected before any work
        else:
            assert isinstance(case, Case)
