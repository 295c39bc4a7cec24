#!/usr/bin/env python3
"""compare_outputs.py A B: compares two output trees file by file, with run stamps
(YYYYMMDDTHHMMSSZ), EXR/TIFF DateTime, timings, paths and hashes of stamped files
taken out. Prints the differing files; exit 1 if any."""
import json, os, re, sys

STAMP = re.compile(r'\d{8}T\d{6}Z')
DROP = re.compile(r'(sha256|seconds|time|timing|date|created|path|dir|folder|host|version|run_id|elapsed|cpu|rss|memory|threads)', re.I)

def norm_name(p): return STAMP.sub('<stamp>', p)

def files(root):
    out = {}
    for dp, _, fn in os.walk(root):
        for f in fn:
            full = os.path.join(dp, f)
            out[norm_name(os.path.relpath(full, root))] = full
    return out

def clean(v):
    if isinstance(v, dict): return {k: clean(x) for k, x in sorted(v.items()) if not DROP.search(k)}
    if isinstance(v, list): return [clean(x) for x in v]
    if isinstance(v, str):
        v = re.sub(r'/[^\s",]*/', '<path>/', v); v = STAMP.sub('<stamp>', v)
        v = re.sub(r'\d+(\.\d+)? ?(ms|s)\b', '<t>', v)
    return v

def text_norm(path):
    out = []
    for line in open(path, errors='replace'):
        line = re.sub(r'/\S*/', '<path>/', line); line = STAMP.sub('<stamp>', line)
        if re.search(r'time|seconds|threads|took|cpu|rss|MB/s|GB/s', line, re.I): continue
        out.append(re.sub(r'\d+(\.\d+)? ?(ms|s)\b', '<t>', line))
    return out

def blank(path):
    b = open(path, 'rb').read()
    b = re.sub(rb'\d{4}:\d\d:\d\d \d\d:\d\d:\d\d', b'0000:00:00 00:00:00', b)
    return re.sub(rb'\d{8}T\d{6}Z', b'00000000T000000Z', b)

def png_chunks(path):
    """The PNG's chunks with stamps blanked in their data, CRCs left out."""
    import struct
    data = open(path, 'rb').read()
    out, i = [data[:8]], 8
    while i + 8 <= len(data):
        n, kind = struct.unpack('>I4s', data[i:i + 8])
        body = data[i + 8:i + 8 + n]
        out.append(kind + STAMP.sub('<stamp>', body.decode('latin-1')).encode('latin-1'))
        i += 12 + n
    return out

def image_same(a, b):
    if a.lower().endswith('.png'): return png_chunks(a) == png_chunks(b)
    return blank(a) == blank(b)

def same(a, b):
    ext = os.path.splitext(a)[1].lower()
    if ext == '.log': return True
    if ext == '.json':
        try: return clean(json.load(open(a))) == clean(json.load(open(b)))
        except Exception: return open(a, 'rb').read() == open(b, 'rb').read()
    if ext in ('.txt', '.csv', '.md', '.html', '.mtlx', '.gltf', '.svg'): return text_norm(a) == text_norm(b)
    if ext in ('.exr', '.tif', '.tiff', '.png'): return image_same(a, b)
    return blank(a) == blank(b)

def main():
    fa, fb = files(sys.argv[1]), files(sys.argv[2])
    bad = 0
    for k in sorted(set(fa) - set(fb)): print('    only in reference:', k); bad = 1
    for k in sorted(set(fb) - set(fa)): print('    only in new:', k); bad = 1
    for k in sorted(set(fa) & set(fb)):
        if not same(fa[k], fb[k]):
            print('    differs:', k); bad = 1
            if k.endswith('.json'):
                import difflib
                A = json.dumps(clean(json.load(open(fa[k]))), indent=1, sort_keys=True).split('\n')
                B = json.dumps(clean(json.load(open(fb[k]))), indent=1, sort_keys=True).split('\n')
                for l in list(difflib.unified_diff(A, B, lineterm='', n=0))[2:12]: print('      ' + l)
    sys.exit(bad)

main()
