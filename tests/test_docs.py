"""The README's case-key table is the code's own reference (docs that match the code)."""

from pathlib import Path

from cablefem.case import format_case_reference


import pytest


@pytest.mark.parametrize("marker,network", [("case-keys", False), ("network-keys", True)])
def test_readme_case_keys_current(marker, network):
    text = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    block = text.split(f"<!-- {marker}:start -->")[1].split(f"<!-- {marker}:end -->")[0]
    assert block.strip() == format_case_reference(markdown=True, network=network).strip(), (
        "README.md is out of date: run .venv/bin/python .ci/readme_keys.py")
