import collections
import re
import sys

text = open(sys.argv[1]).read()


def table(name, nxt):
    s = text.index("\n" + name + "\n") + len(name) + 2
    e = text.index("\n" + nxt + "\n", s) if nxt else text.index("\n\n", s)
    return [x for x in text[s:e].split("\n") if x.strip()]


files = {
    int(l.split()[0]): l.split('"')[1].split("site-packages/")[-1].split("/work/main/")[-1]
    for l in table("FileNames", "FunctionNames")
}
locs = {}
for l in table("FileLocations", "StackFrames"):
    m = re.match(r"(\d+) \{file_name_id=(\d+) function_name_id=(\d+) line=(\d+)", l)
    locs[int(m[1])] = (files[int(m[2])], int(m[4]))
frames = {}
for l in table("StackFrames", None):
    m = re.match(r"(\d+) \{file_location_id=(\d+) parent_frame_id=(\d+)", l)
    if m:
        frames[int(m[1])] = (int(m[2]), int(m[3]))
fusion_bodies = (
    set(re.findall(r"fusion\([^\n]*calls=%?([\w.\-]+)", text))
    | set(re.findall(r"to_apply=%?([\w.\-]+)", text))
    | set(re.findall(r"comparator=%?([\w.\-]+)", text))
)
skip = {"parameter", "constant", "get-tuple-element", "tuple", "bitcast", "after-all", "opt-barrier"}
ops = collections.Counter()
inner = collections.Counter()
outer = collections.Counter()
lines = collections.Counter()
body = text[: text.index("\nFileNames\n")] if False else text
name = None
for line in text.split("\n"):
    h = re.match(r"(?:ENTRY )?%([\w.\-]+) [^\n]*\{$", line)
    if h:
        name = h.group(1)
        continue
    if name is None or name in fusion_bodies:
        continue
    mm = re.match(r"\s*(?:ROOT )?%[\w.\-]+ = [^=]*? ([a-z\-]+)\(", line)
    if not mm or mm.group(1) in skip:
        continue
    ops[mm.group(1)] += 1
    f = re.search(r"stack_frame_id=(\d+)", line)
    chain = []
    fid = int(f.group(1)) if f else 0
    while fid in frames and fid:
        loc, parent = frames[fid]
        chain.append(locs[loc])
        if parent == fid:
            break
        fid = parent
    inner[chain[0][0] if chain else "?"] += 1
    lines[chain[0] if chain else "?"] += 1
    for fn in {c[0] for c in chain} or {"?"}:
        outer[fn] += 1
print("thunk-level ops", sum(ops.values()), ops.most_common(12))
print("-- by innermost file")
[print(f"{v:6d} {k}") for k, v in inner.most_common(25)]
print("-- by any file on the stack")
[print(f"{v:6d} {k}") for k, v in outer.most_common(25)]
print("-- by innermost line")
[print(f"{v:6d} {k}") for k, v in lines.most_common(20)]
