"""The README's case-key table is the code's own reference (docs that match the code)."""

from pathlib import Path

from cablefem.case import format_case_reference


def test_readme_case_keys_current():
    text = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    block = text.split("<!-- case-keys:start -->")[1].split("<!-- case-keys:end -->")[0]
    assert block.strip() == format_case_reference(markdown=True).strip(), (
        "README.md is out of date: run .venv/bin/python .ci/readme_keys.py")
