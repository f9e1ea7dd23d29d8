"""Per scan folder, what bench/register_variants.sh pools: for each setting and each <kind>_<scans folder> it ran, the
median over the scans of the per-scan correspondence median and p95, and the per-scan p95s (to count scans that got
better or worse). Usage: /usr/bin/python3 bench/register_sets.py OUT NAME...   (OUT and the names as given to
register_variants.sh)"""
import glob, json, os, statistics as st, sys

out, names = sys.argv[1], sys.argv[2:]
for name in names:
    cells = []
    for folder in sorted(glob.glob(f"{out}/{name}/*_*/")):
        reps = [json.load(open(p)) for p in sorted(glob.glob(f"{folder}subject_*/report.json"))]
        if not reps:
            continue
        med = [r["correspondence_error_mm"]["median"] for r in reps]
        p95 = [r["correspondence_error_mm"]["p95"] for r in reps]
        cells.append(f"{os.path.basename(folder.rstrip('/'))}({len(reps)}) median {st.median(med):.3f} p95 "
                     f"{st.median(p95):.3f} [" + " ".join(f"{v:.2f}" for v in p95) + "]")
    print(f"{name:<16} " + " | ".join(cells))
