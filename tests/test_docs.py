"""The README's case-key table is the code's own reference (docs that match the code); the
repository documents itself (no reference outside it, docs/theory.md citations resolve)."""

import re
import subprocess
from pathlib import Path

import pytest

from cablefem.case import format_case_reference


@pytest.mark.parametrize("marker,network", [("case-keys", False), ("network-keys", True)])
def test_readme_case_keys_current(marker, network):
    text = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    block = text.split(f"<!-- {marker}:start -->")[1].split(f"<!-- {marker}:end -->")[0]
    assert block.strip() == format_case_reference(markdown=True, network=network).strip(), (
        "README.md is out of date: run .venv/bin/python .ci/readme_keys.py")


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
