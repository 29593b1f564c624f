#!/usr/bin/python3
"""In-plane load variants of sweep 2's sheets, through `rodmesh simulate`.

    /usr/bin/python3 benchmarks/sweep2/inplane.py --rodmesh BIN --cases CASES --out DIR

CASES is make.py's output. The hex and quad sheets of sweep 2 (clamped or
pinned along their left side) get their four right-side vertices loaded in
their plane (compression, shear, tension, 45 degrees between compression and
shear) at 0.003 to 3 N each: 80 runs, about a minute. One line per run: exit
status, wall time, and the pose line of `simulate`.
"""
import argparse
import json
import os
import subprocess
import time

TEMPLATES = {'hex_clamped': 'planarclamped_hex_compress_0.1N.json', 'hex_pinned': 'planar_hex_compress_0.1N.json',
             'quad_clamped': 'planarclamped_quad_compress_0.1N.json', 'quad_pinned': 'planar_quad_compress_0.1N.json'}
DIRECTIONS = {'compress': (-1, 0, 0), 'shear': (0, 1, 0), 'tension': (1, 0, 0), 'diag': (-0.7071, 0.7071, 0)}
MAGNITUDES = (0.003, 0.03, 0.3, 1.0, 3.0)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('--rodmesh', required=True)
    ap.add_argument('--cases', required=True)
    ap.add_argument('--out', required=True)
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    failures = 0
    for tn, tf in TEMPLATES.items():
        with open(os.path.join(a.cases, tf)) as f:
            base = json.load(f)
        for dn, d in DIRECTIONS.items():
            for mag in MAGNITUDES:
                s = json.loads(json.dumps(base))
                for force in s['poses'][0]['forces']:
                    force['force'] = [mag * c for c in d]
                name = '%s_%s_%g' % (tn, dn, mag)
                scene = os.path.join(a.out, name + '.json')
                with open(scene, 'w') as f:
                    json.dump(s, f)
                t0 = time.time()
                r = subprocess.run([a.rodmesh, 'simulate', scene, '-o', os.path.join(a.out, name + '.h5')],
                                   capture_output=True, text=True, timeout=600)
                lines = [l for l in (r.stdout + r.stderr).splitlines() if l.startswith('pose 0')]
                failures += r.returncode != 0
                print('%-28s exit %d %6.2fs %s' % (name, r.returncode, time.time() - t0, lines[-1][:150] if lines else ''),
                      flush=True)
    print('%d of %d runs exit 0' % (len(TEMPLATES) * len(DIRECTIONS) * len(MAGNITUDES) - failures,
                                    len(TEMPLATES) * len(DIRECTIONS) * len(MAGNITUDES)))


if __name__ == '__main__':
    main()
