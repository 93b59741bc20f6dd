#!/usr/bin/env bash
# Reproduces the GLS-PIA paper's §6 (Tables 1-3, Figures 7-12) on S^2 and writes them into
# docs/paper.md, between the markers "<!-- tables:begin -->" and "<!-- tables:end -->", with
# one PNG per example in docs/paper/.
#
#   scripts/paper_tables.sh
#
# 1. `cargo run --release --example paper_tables -- target/paper` fits every example with
#    every knot placement and method (examples/paper_tables.rs) and writes target/paper/
#    tables.md and one JSON per example (data, ground truth, every method's samples);
# 2. scripts/paper_plot.py draws the PNGs with matplotlib from a venv under target/
#    (made on the first run: python3 -m venv, pip install matplotlib==3.9.2);
# 3. the tables are spliced into docs/paper.md; the prose around them is written by hand
#    and says where the numbers differ from the paper's and why.
#
# Run times in the tables are wall-clock on the machine that runs this (best of 3).
set -euo pipefail
cd "$(dirname "$0")/.."
out=target/paper
cargo run --release --example paper_tables -- "$out"
venv=target/paper-venv
if [ ! -x "$venv/bin/python" ] || ! "$venv/bin/python" -c 'import matplotlib' 2>/dev/null; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet matplotlib==3.9.2
fi
"$venv/bin/python" scripts/paper_plot.py "$out" docs/paper
python3 - "$out/tables.md" docs/paper.md <<'PY'
import pathlib, sys
tables = pathlib.Path(sys.argv[1]).read_text()
doc_path = pathlib.Path(sys.argv[2])
doc = doc_path.read_text()
begin, end = "<!-- tables:begin -->", "<!-- tables:end -->"
if begin not in doc or end not in doc:
    sys.exit(f"{doc_path}: the markers {begin} and {end} are missing")
head, rest = doc.split(begin, 1)
_, tail = rest.split(end, 1)
doc_path.write_text(head + begin + "\n" + tables + end + tail)
print(f"wrote the tables into {doc_path}")
PY
