#!/usr/bin/env python3
"""Merges the sweeps.md files of separate runs of sweeps.py (`--only PART ...`)
into one, e.g. the full study's parts run at different times:

    /usr/bin/python3 benchmarks/study/merge_sweeps.py OLD/sweeps.md NEW/sweeps.md ... -o OUT/sweeps.md

Each input is a sweeps.md written by sweeps.py (one run) or by this script
(several runs). The output keeps every run's header (command, mode, start,
commit, machine, load average) and answers together, under "Runs and
answers", and every part's section once, in the order of sweeps.PARTS. A part
present in several inputs is taken from the last one; an earlier run whose
parts were all re-run later is dropped, one with some re-run parts is kept
with a note. Only the Markdown is merged: copy the CSV and PNG files of the
parts next to OUT yourself (the sections link them by relative name).
"""
import argparse
import re
import sys

# The part names in run order (sweeps.PARTS, repeated here so that merging needs no h5py or matplotlib).
PARTS = ["tolerance", "discretization", "fd", "scaling", "threads", "table2"]
SECTION_PART = [("Tolerance sweep", "tolerance"), ("Discretization sweep", "discretization"),
                ("The paper's recipe", "fd"), ("Scaling", "scaling"), ("Threads", "threads"),
                ("Table 2", "table2")]
TITLE = "# Design study: sweeps (issue #10, items 2 and 3)"
RUNS = "## Runs and answers"


def part_of(heading):
    """The part a '## ' section heading belongs to."""
    h = heading[3:].strip()
    m = re.match(r"(\w+): failed$", h)
    if m and m.group(1) in PARTS:
        return m.group(1)
    for prefix, part in SECTION_PART:
        if h.startswith(prefix):
            return part
    raise SystemExit("merge_sweeps.py: no part for the section %r" % heading)


def blocks(lines, prefix):
    """Splits lines at lines starting with prefix: (lines before the first, [block, ...])."""
    head, out = [], []
    for ln in lines:
        if ln.startswith(prefix):
            out.append([ln])
        elif out:
            out[-1].append(ln)
        else:
            head.append(ln)
    return head, out


def strip(lines):
    """Without leading and trailing blank lines, and runs of blank lines made one."""
    lines = [ln for i, ln in enumerate(lines) if ln.strip() or i == 0 or lines[i - 1].strip()]
    while lines and not lines[0].strip():
        lines = lines[1:]
    while lines and not lines[-1].strip():
        lines = lines[:-1]
    return lines


def parse(text):
    """(runs, sections): runs = [dict(parts, header, bullets, note)], sections = {part: lines}."""
    lines = text.rstrip("\n").split("\n")
    head, secs = blocks(lines, "## ")
    runs, sections = [], {}
    for sec in secs:
        if sec[0].startswith("## Answers"):  # one run: its header is above, its answers here
            parts = None
            header = []
            for ln in head[1:]:
                m = re.match(r"Parts run: (.*)\.$", ln)
                if m:
                    parts = [p.strip() for p in m.group(1).split(",") if p.strip()]
                else:
                    header.append(ln)
            if parts is None:
                raise SystemExit("merge_sweeps.py: a sweeps.md without a 'Parts run:' line")
            runs.append(dict(parts=parts, header=strip(header), bullets=strip(sec[1:]), note=""))
        elif sec[0].startswith(RUNS):
            _, rb = blocks(sec[1:], "### Parts ")
            for b in rb:
                parts = [p.strip() for p in b[0][len("### Parts "):].split(",")]
                body = strip(b[1:])
                note = ""
                if body and body[0].startswith("*Re-run later"):
                    note, body = body[0], strip(body[1:])
                first = next((i for i, ln in enumerate(body) if ln.startswith("- ")), len(body))
                runs.append(dict(parts=parts, header=strip(body[:first]), bullets=strip(body[first:]), note=note))
        else:
            sections[part_of(sec[0])] = strip(sec)
    return runs, sections


def merge(texts):
    runs, sections = [], {}
    for text in texts:
        r, s = parse(text)
        new = {p for x in r for p in x["parts"]}
        kept = []
        for x in runs:
            again = [p for p in x["parts"] if p in new]
            if len(again) == len(x["parts"]):
                continue
            if again:
                x["note"] = ("*Re-run later: %s; this run's answers on %s are superseded by the later run's.*" %
                             (", ".join(again), "them" if len(again) > 1 else "it"))
            kept.append(x)
        runs = kept + r
        sections.update(s)
    out = [TITLE, "",
           "Merged by `benchmarks/study/merge_sweeps.py` from %d separate run%s of `benchmarks/study/sweeps.py` "
           "(`--only PART ...`); each run's command, mode, start, commit, machine and load average are given with "
           "its answers below, each part's section follows once." % (len(runs), "s" if len(runs) > 1 else ""), "",
           RUNS, ""]
    for x in runs:
        out += ["### Parts " + ", ".join(x["parts"]), ""]
        if x["note"]:
            out += [x["note"], ""]
        out += x["header"] + [""] + x["bullets"] + [""]
    for p in PARTS:
        if p in sections:
            out += sections[p] + [""]
    return "\n".join(out).rstrip("\n") + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("inputs", nargs="+", help="sweeps.md files, oldest first")
    ap.add_argument("-o", "--out", required=True)
    a = ap.parse_args()
    text = merge([open(p).read() for p in a.inputs])
    open(a.out, "w").write(text)
    print("wrote", a.out, file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
