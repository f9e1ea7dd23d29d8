"""The table bench/register_model.sh and bench/register_texture.sh print: one row per registered scan, from the
report.json files under OUT/<prefix><kind>_<scans folder>/<subject>/, for the true and the detected landmarks, then
the medians of each column over the scans of that kind."""
import glob
import json
import os
import statistics as st


def table(out, prefix, groups, row, name_width):
    """groups: the columns between '|' separators, each (header, width, decimals, value); value is the index into the
    row's values, or a function of them (a ratio), which the median row computes again from the medians.
    row(kind, report path, report): the scan's values, or None to leave it out."""
    header = f"{'landmarks':<9} {'scan':<{name_width}}"
    for group in groups:
        header += " | " + " ".join(f"{h:>{w}}" for h, w, _, _ in group)
    print(header)

    def line(kind, name, values):
        text = f"{kind:<9} {name:<{name_width}}"
        for group in groups:
            text += " | " + " ".join(f"{(v(values) if callable(v) else values[v]):{w}.{d}f}" for _, w, d, v in group)
        print(text)

    for kind in ("true", "detected"):
        rows = []
        for path in sorted(glob.glob(f"{out}/{prefix}{kind}_*/subject_*/report.json")):
            values = row(kind, path, json.load(open(path)))
            if values is None:
                continue
            rows.append(values)
            subject_dir = os.path.dirname(path)
            scans = os.path.basename(os.path.dirname(subject_dir))[len(f"{prefix}{kind}_"):]
            line(kind, scans + "/" + os.path.basename(subject_dir), values)
        if rows:
            line(kind, f"MEDIAN of {len(rows)} scans", [st.median(c) for c in zip(*rows)])
