"""The documentation matches the code: the case-key tables of docs/case-file.md are the
code's own reference, the paper's cases' static numbers quoted in docs/verification.md and
the README are what a run gives, every relative link resolves; the repository documents
itself (no reference outside it, docs/theory.md citations resolve)."""

import re
import subprocess
from decimal import Decimal
from pathlib import Path

import pytest

from cablefem.case import format_case_reference

pytestmark = pytest.mark.single_rank  # the docs and the quoted numbers: nothing distributed


@pytest.mark.parametrize("marker,network", [("case-keys", False), ("network-keys", True)])
def test_case_file_keys_current(marker, network):
    text = (Path(__file__).resolve().parents[1] / "docs" / "case-file.md").read_text()
    block = text.split(f"<!-- {marker}:start -->")[1].split(f"<!-- {marker}:end -->")[0]
    assert block.strip() == format_case_reference(markdown=True, network=network).strip(), (
        "docs/case-file.md is out of date: run .venv/bin/python .ci/case_keys.py")


def test_loadset_keys_current():
    from cablefem.case.loadset import format_loadset_reference

    text = (Path(__file__).resolve().parents[1] / "docs" / "loadsets.md").read_text()
    block = text.split("<!-- loadset-keys:start -->")[1].split("<!-- loadset-keys:end -->")[0]
    assert block.strip() == format_loadset_reference(markdown=True).strip(), (
        "docs/loadsets.md is out of date: run .venv/bin/python .ci/case_keys.py")


# ------------------------------------------------- the repository documents itself
# Users clone the repository only: no file may point outside it, and every citation of
# docs/theory.md ("docs/theory.md §3, step 1", "§3-4", "§8 and §9") must name a section,
# subsection or step that the document has.
ROOT = Path(__file__).resolve().parents[1]
OUTSIDE = ("../shared", "physics" + ".md", "000_00e55630" + "a62489f6")
CITATION = re.compile(r"§(\d+)(?:\.(\d+))?(?:-(\d+))?(?:,\s*steps?\s+(\d+)(?:-(\d+))?)?")


def _tracked_texts():
    """(name, text) of every tracked text file but this one."""
    try:
        out = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True,
                             check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout (git ls-files failed)")
    me = Path(__file__).resolve()
    for name in out.decode().split("\0"):
        path = ROOT / name
        if not name or not path.is_file() or path.resolve() == me:
            continue
        try:
            yield name, path.read_text(encoding="utf-8")
        except UnicodeDecodeError:  # binary files
            continue


def _theory_headings():
    """Sections (n,), subsections (n, m) and steps (n, k) of docs/theory.md."""
    sections, steps, current = set(), set(), None
    for line in (ROOT / "docs" / "theory.md").read_text(encoding="utf-8").splitlines():
        if m := re.match(r"## (\d+)\. ", line):
            current = int(m[1])
            sections.add((current,))
        elif m := re.match(r"### (\d+)\.(\d+) ", line):
            sections.add((int(m[1]), int(m[2])))
        elif (m := re.match(r"### Step (\d+)\. ", line)) and current is not None:
            steps.add((current, int(m[1])))
    return sections, steps


def test_no_reference_outside_the_repository():
    files = dict(_tracked_texts())
    assert "README.md" in files and "cablefem/asymptotics.py" in files
    bad = [f"{name}:{text.count(chr(10), 0, text.index(s)) + 1}: {s!r}"
           for name, text in files.items() for s in OUTSIDE if s in text]
    assert not bad, "references to files outside the repository:\n" + "\n".join(bad)

    sections, steps = _theory_headings()
    assert {(n,) for n in range(1, 10)} <= sections, sorted(sections)
    cited, missing = 0, []
    for name, text in files.items():
        if name == "docs/theory.md":
            continue
        for hit in re.finditer(r"theory\.md", text):
            window = text[hit.end():hit.end() + 200].split("theory.md")[0]
            for m in CITATION.finditer(window):
                n, sub, last, k0, k1 = (int(g) if g else None for g in m.groups())
                want = [(n, sub)] if sub is not None else [(i,) for i in range(n, (last or n) + 1)]
                want_steps = [(n, k) for k in range(k0, (k1 or k0) + 1)] if k0 else []
                cited += 1
                line = text.count("\n", 0, hit.start()) + 1
                missing += [f"{name}:{line}: {m[0]!r} (no heading {w})"
                            for w in want if w not in sections]
                missing += [f"{name}:{line}: {m[0]!r} (no step {k} in §{n})"
                            for n, k in want_steps if (n, k) not in steps]
    assert cited > 30, f"only {cited} citations of docs/theory.md found: parser broken?"
    assert not missing, "citations of docs/theory.md without a heading:\n" + "\n".join(missing)


# ------------------------------------------------------ every relative link resolves
LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)\)")


def test_relative_links_resolve():
    """Every relative link [text](target) in README.md and docs/*.md names a file of the
    repository (the #anchor part is not checked), so a reader never lands on nothing."""
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
    links, broken = 0, []
    for page in pages:
        text = page.read_text(encoding="utf-8")
        for m in LINK.finditer(text):
            target = m[1].split("#", 1)[0]
            if not target or re.match(r"[a-z]+:", target):  # in-page anchor, URL
                continue
            links += 1
            if not (page.parent / target).exists():
                line = text.count("\n", 0, m.start()) + 1
                broken.append(f"{page.relative_to(ROOT)}:{line}: {m[1]}")
    assert links > 40, f"only {links} relative links found: parser broken?"
    assert not broken, "links to missing files:\n" + "\n".join(broken)


# ------------------------------- the paper's cases: the numbers the documentation quotes
def _cells(text: str, row_start: str) -> list[str]:
    """The cells after the first of a markdown table row that starts with row_start."""
    line = next(ln for ln in text.splitlines() if ln.startswith("| " + row_start))
    return [c.strip() for c in line.strip().strip("|").split("|")][1:]


def _numbers(cell: str) -> list[str]:
    return re.findall(r"[-+]?\d+\.\d+(?:e[-+]?\d+)?", cell)


def _quoted(text: str, value: float) -> bool:
    """text is value rounded to the digits it shows (one unit of its last digit: a value
    next to a rounding boundary may round either way on another machine's BLAS)."""
    ulp = float(Decimal(1).scaleb(Decimal(text).as_tuple().exponent))
    return abs(float(text) - value) <= ulp


@pytest.fixture(scope="module")
def paper_statics(tmp_path_factory):
    from mpi4py import MPI

    from cablefem.app.run import run_case
    from cablefem.case import load_case
    from cablefem.verify import closed_form_anchor_moments

    out = {}
    for name in ("paper_inplane", "paper_spatial"):
        for route in ("none", "hinge"):  # the leading order, the default
            case = load_case(ROOT / "demos" / f"{name}.toml")
            case.solver.outer_correction = route
            folder = MPI.COMM_WORLD.bcast(str(tmp_path_factory.mktemp(name)), root=0)
            s = run_case(case, folder, dynamics=False, figures=False, progress=False).summary
            sym = "symmetric" if name == "paper_inplane" else "antisymmetric"
            out[name if route == "none" else f"{name}_default"] = dict(
                s["anchors"]["p"], closed_form=closed_form_anchor_moments(case)["p"]["moment"],
                omega=next(m["omega"] for m in s["modes"] if m["plane"] == "in-plane"
                           and m["symmetry"] == sym))
    return out


def test_paper_numbers_quoted_are_computed(paper_statics):
    """docs/verification.md's table of the paper's two cases (and the README's short one)
    quote the static anchor tension, angle, layer length, moment (and the layer's part), the
    closed form with the exact catenary, the FE's relative difference to it and the string's
    own frequency of the leading order, and the static moment by default: each is what a
    static run of demos/paper_*.toml gives, to the digits shown."""
    ver = (ROOT / "docs" / "verification.md").read_text(encoding="utf-8")
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    rows = {"tension": _cells(ver, "static tension at the anchors"),
            "angle": _cells(ver, "static anchor angle"),
            "moment": _cells(ver, "static anchor moment `M_p"),
            "closed": _cells(ver, "closed form with the exact catenary"),
            "omega": _cells(ver, "string's own frequency"),
            "default": _cells(ver, "static anchor moment by default"),
            "readme": _cells(readme, "static anchor moment (FE string")}
    bad = []
    for k, name in enumerate(("paper_inplane", "paper_spatial")):
        r, d = paper_statics[name], paper_statics[f"{name}_default"]
        want = {"tension": [r["static_tension"]],
                "angle": [r["static_delta"], r["layer_length"]],
                "moment": [r["static_moment"], r["static_moment_layer"]],
                "closed": [r["closed_form"], r["static_moment"] / r["closed_form"] - 1],
                "omega": [r["omega"]],
                "default": [d["static_moment"], d["omega"]],
                "readme": [d["static_moment"], r["static_moment"], r["closed_form"]]}
        for row, values in want.items():
            quoted = _numbers(rows[row][k])[:len(values)]
            if len(quoted) != len(values):
                bad.append(f"{row}, {name}: cannot read {rows[row][k]!r}")
            bad += [f"{row}, {name}: quoted {q}, computed {v:.6g}"
                    for q, v in zip(quoted, values) if not _quoted(q, v)]
    assert not bad, "numbers in the documentation that a run does not give:\n" + "\n".join(bad)


def test_every_csv_column_has_a_unit():
    """docs/outputs.md's table of units names every column the run writes to anchors.csv,
    kinks.csv and touchdown.csv (the headers carry names only), once, with a unit."""
    from cablefem.app.touchdownout import TOUCHDOWN_COLUMNS
    from cablefem.io.anchorcsv import ANCHOR_COLUMNS, MOMENT_COLUMNS
    from cablefem.io.dampercsv import DAMPER_COLUMNS
    from cablefem.kinks import KINK_COLUMNS

    text = (ROOT / "docs" / "outputs.md").read_text()
    block = text.split("<!-- csv-units:start -->")[1].split("<!-- csv-units:end -->")[0]
    documented: dict[str, list[str]] = {}
    for line in block.strip().splitlines()[2:]:
        file, names, unit, what = (c.strip() for c in line.strip("|").split("|"))
        assert unit and what, line
        documented.setdefault(file, []).extend(re.findall(r"`([^`]+)`", names))
    written = {"anchors.csv": ANCHOR_COLUMNS + MOMENT_COLUMNS, "kinks.csv": KINK_COLUMNS,
               "touchdown.csv": TOUCHDOWN_COLUMNS, "dampers.csv": DAMPER_COLUMNS}
    for file, columns in written.items():
        assert sorted(documented.get(file, [])) == sorted(columns), file
