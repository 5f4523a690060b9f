"""How the benchmarks write their results: CSV files of the rows and Markdown tables.

    from report import table, write_csv, write_report
    columns = [("elements", "{}"), ("ms_per_step", "{:.2f}", "ms/step"),
               ("F_J", "{F_ms:.1f} / {J_ms:.1f}", "F / J ms"),
               ("order", lambda r: "" if r["order"] is None else f"{r['order']:.2f}")]
    lines = table(rows, columns)     # the Markdown table: header, |---|..., one line per row
    write_csv("four_bar", rows)      # benchmarks/four_bar.csv, a column per key of the first row
    write_report("four_bar", rows, columns, title="Four-bar mechanism: cost per step", notes=["..."])

rows are dicts.  A column is (key, format) or (key, format, header), the header by default the
key; format is a str.format pattern, given the row's value under key as {} and every key of the
row by name, or a callable of the row that returns the cell.  write_report writes <name>.csv and
<name>.md (a title, intro lines, the table, notes) and prints the Markdown.
"""
import csv
import os

HERE = os.path.dirname(os.path.abspath(__file__))


def table(rows, columns):
    """The lines of a Markdown table of rows, one column per entry of columns (see above)."""
    def cell(r, key, fmt):
        return fmt(r) if callable(fmt) else fmt.format(r.get(key), **r)
    heads = [c[2] if len(c) > 2 else c[0] for c in columns]
    return ["| " + " | ".join(heads) + " |", "|" + "---|" * len(columns),
            *("| " + " | ".join(cell(r, key, fmt) for key, fmt, *_ in columns) + " |" for r in rows)]


def write_csv(path_or_name, rows, fieldnames=None, title=None):
    """rows as CSV, a column per field of fieldnames (by default the keys of the first row); other
    keys are left out, missing ones and None written empty.  path_or_name: a path, a bare name
    (HERE/<name>.csv) or an open file (several tables in one file); title: a first row "# title"."""
    if not hasattr(path_or_name, "write"):
        path = path_or_name if path_or_name.endswith(".csv") else os.path.join(HERE, f"{path_or_name}.csv")
        with open(path, "w", newline="") as f:
            return write_csv(f, rows, fieldnames, title)
    if title is not None:
        csv.writer(path_or_name).writerow([f"# {title}"])
    w = csv.DictWriter(path_or_name, fieldnames=fieldnames or list(rows[0]), extrasaction="ignore")
    w.writeheader()
    w.writerows(rows)


def write_report(name, rows, columns, title, intro=(), notes=(), directory=HERE):
    """<name>.csv (every key of the rows) and <name>.md (title, intro, table(rows, columns), notes)."""
    write_csv(os.path.join(directory, f"{name}.csv"), rows)
    lines = [f"# {title}", "", *intro, *([""] if intro else []), *table(rows, columns)]
    if notes:
        lines += ["", *notes]
    text = "\n".join(lines) + "\n"
    with open(os.path.join(directory, f"{name}.md"), "w") as f:
        f.write(text)
    print(text)
    return text
