"""Regenerate the case-key table of README.md from the code (tests/test_docs.py checks it).

    .venv/bin/python .ci/readme_keys.py
"""

from pathlib import Path

from cablefem.case import format_case_reference

readme = Path(__file__).resolve().parents[1] / "README.md"
text = readme.read_text()
head, rest = text.split("<!-- case-keys:start -->")
_, tail = rest.split("<!-- case-keys:end -->")
table = format_case_reference(markdown=True).strip()
readme.write_text(f"{head}<!-- case-keys:start -->\n{table}\n<!-- case-keys:end -->{tail}")
print(f"updated {readme}")
