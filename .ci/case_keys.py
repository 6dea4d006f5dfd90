"""Regenerate the case-key tables of docs/case-file.md and the set-file keys of
docs/loadsets.md from the code (tests/test_docs.py checks that they are current).

    .venv/bin/python .ci/case_keys.py
"""

from pathlib import Path

from cablefem.case import format_case_reference
from cablefem.case.loadset import format_loadset_reference

page = Path(__file__).resolve().parents[1] / "docs" / "case-file.md"
text = page.read_text()
for marker, network in (("case-keys", False), ("network-keys", True)):
    head, rest = text.split(f"<!-- {marker}:start -->")
    _, tail = rest.split(f"<!-- {marker}:end -->")
    table = format_case_reference(markdown=True, network=network).strip()
    text = f"{head}<!-- {marker}:start -->\n{table}\n<!-- {marker}:end -->{tail}"
page.write_text(text)
print(f"updated {page}")

page = page.with_name("loadsets.md")
head, rest = page.read_text().split("<!-- loadset-keys:start -->")
_, tail = rest.split("<!-- loadset-keys:end -->")
table = format_loadset_reference(markdown=True).strip()
page.write_text(f"{head}<!-- loadset-keys:start -->\n{table}\n<!-- loadset-keys:end -->{tail}")
print(f"updated {page}")
