"""Regenerate the case-key table of README.md from the code (tests/test_docs.py checks it).

    .venv/bin/python .ci/readme_keys.py
"""

from pathlib import Path

from cablefem.case import format_case_reference

readme = Path(__file__).resolve().parents[1] / "README.md"
text = readme.read_text()
for marker, network in (("case-keys", False), ("network-keys", True)):
    head, rest = text.split(f"<!-- {marker}:start -->")
    _, tail = rest.split(f"<!-- {marker}:end -->")
    table = format_case_reference(markdown=True, network=network).strip()
    text = f"{head}<!-- {marker}:start -->\n{table}\n<!-- {marker}:end -->{tail}"
readme.write_text(text)
print(f"updated {readme}")
