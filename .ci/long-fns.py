#!/usr/bin/env python3
# Usage: python3 .ci/long-fns.py [--check] [LIMIT [DIR]] (default 80 src): the functions over
# LIMIT lines, longest first. With --check, only those not in ALLOWED below, and the exit status
# is 1 when there are any (.ci/run uses it).
# Lists Rust functions longer than N lines (default 80): from the `fn` line to its closing brace,
# found by brace matching (strings, chars and comments skipped roughly).
import sys, re, glob
# The long functions allowed, as (file, function).
ALLOWED = {
    # the integrator's loop: one step of the integration, kept whole to be read as one
    ('physics/integrator.rs', 'integrate_until'),
}
args = sys.argv[1:]
check = '--check' in args
args = [a for a in args if a != '--check']
limit = int(args[0]) if len(args) > 0 else 80
root = args[1] if len(args) > 1 else 'src'
fn_re = re.compile(r'^\s*(pub(\([^)]*\))?\s+)?(const\s+)?(async\s+)?(unsafe\s+)?(extern\s+"[^"]*"\s+)?fn\s+(\w+)')
def strip(line):
    # drop line comments and string contents
    out, i, n = [], 0, len(line)
    in_str = False
    while i < n:
        c = line[i]
        if in_str:
            if c == '\\': i += 2; continue
            if c == '"': in_str = False
            i += 1; continue
        if c == '"': in_str = True; i += 1; continue
        if c == "'" and i + 2 < n and (line[i+2] == "'" or (line[i+1] == '\\' and "'" in line[i+2:i+5])):
            j = line.index("'", i + 2 if line[i+1] != '\\' else i + 3); i = j + 1; continue
        if line.startswith('//', i): break
        out.append(c); i += 1
    return ''.join(out), in_str
res = []
for f in sorted(glob.glob(root + '/**/*.rs', recursive=True)):
    lines = open(f).read().split('\n')
    i = 0
    while i < len(lines):
        m = fn_re.match(lines[i])
        if m:
            name, start, depth, opened, j = m.group(7), i, 0, False, i
            in_str = False
            while j < len(lines):
                s, _ = strip(lines[j])
                if not opened and s.rstrip().endswith(';') and '{' not in s:
                    break  # declaration without body
                depth += s.count('{') - s.count('}')
                if '{' in s: opened = True
                if opened and depth <= 0: break
                j += 1
            if opened:
                res.append((j - start + 1, f, start + 1, name))
        i += 1
def allowed(f, name):
    rel = f[len(root):].lstrip('/') if f.startswith(root) else f
    return (rel, name) in ALLOWED
found = 0
for n, f, l, name in sorted(res, reverse=True):
    if n > limit and not (check and allowed(f, name)):
        print(f"{n:5} {f}:{l} {name}")
        found += 1
if check and found:
    print(f"{found} function(s) over {limit} lines: split them (or, for a reason, add to ALLOWED "
          "in .ci/long-fns.py)", file=sys.stderr)
    sys.exit(1)
