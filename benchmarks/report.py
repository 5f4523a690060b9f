"""One way for the benchmarks to write their results: a CSV of the rows and a Markdown table.

    from report import write_report
    write_report("four_bar", rows, [("elements", "{}"), ("ms_per_step", "{:.2f}")],
                 title="Four-bar mechanism: cost per step", notes=["..."])

writes benchmarks/four_bar.csv (every key of the rows) and benchmarks/four_bar.md (a title, the
columns given, in that order and format, and the notes), and prints the table.
"""
import csv
import os

HERE = os.path.dirname(os.path.abspath(__file__))


def write_report(name, rows, columns, title, intro=(), notes=(), directory=HERE):
    """rows: list of dicts; columns: [(key, format) or (key, format, header)]."""
    with open(os.path.join(directory, f"{name}.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    heads = [c[2] if len(c) > 2 else c[0] for c in columns]
    lines = [f"# {title}", "", *intro, *([""] if intro else []),
             "| " + " | ".join(heads) + " |", "|" + "---|" * len(columns)]
    for r in rows:
        lines.append("| " + " | ".join(fmt.format(r[key]) for key, fmt, *_ in columns) + " |")
    if notes:
        lines += ["", *notes]
    text = "\n".join(lines) + "\n"
    with open(os.path.join(directory, f"{name}.md"), "w") as f:
        f.write(text)
    print(text)
    return text
