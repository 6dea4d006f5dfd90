"""Regenerate the case-key tables of docs/case-file.md from the code (tests/test_docs.py
checks that they are current).

    .venv/bin/python .ci/case_keys.py
"""

from pathlib import Path

from cablefem.case import format_case_reference

page = Path(__file__).resolve().parents[1] / "docs" / "case-file.md"
text = page.read_text()
for marker, network in (("case-keys", False), ("network-keys", True)):
    head, rest = text.split(f"<!-- {marker}:start -->")
    _, tail = rest.split(f"<!-- {marker}:end -->")
    table = format_case_reference(markdown=True, network=network).strip()
    text = f"{head}<!-- {marker}:start -->\n{table}\n<!-- {marker}:end -->{tail}"
page.write_text(text)
print(f"updated {page}")
