#!/usr/bin/env python3
"""The 5-axis example table regenerated with other row counts (same curve, same analytic
derivatives; scripts/gen-examples.py's approach/machining row counts 117/175 scaled), to check
that the planner's motion and work do not hinge on how densely a table samples its path.

    python3 benches/robustness/table_variants.py OUTDIR [FACTOR ...]   # default 0.5 1.5 2 3

Writes OUTDIR/table_<approach rows>_<machining rows>.csv.
"""
import importlib.util
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]
APPROACH_ROWS, MACHINING_ROWS = 117, 175


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    out = pathlib.Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    factors = [float(x) for x in sys.argv[2:]] or [0.5, 1.5, 2.0, 3.0]
    spec = importlib.util.spec_from_file_location("gen", ROOT / "scripts" / "gen-examples.py")
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    sample_piece = gen.sample_piece
    for f in factors:
        na, nm = int(APPROACH_ROWS * f), int(MACHINING_ROWS * f)
        gen.sample_piece = lambda fn, n, s0, tl, na=na, nm=nm: sample_piece(fn, na if n == APPROACH_ROWS else nm, s0, tl)
        gen.write = lambda name, text, na=na, nm=nm: (out / f"table_{na}_{nm}.csv").write_text(text)
        gen.five_axis()
        print(out / f"table_{na}_{nm}.csv")


if __name__ == "__main__":
    main()
