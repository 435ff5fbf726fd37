#!/usr/bin/env python3
"""Copies each real level of data/levels with its levels.json sun and camera
written into the glTF — a KHR_lights_punctual directional light replacing the
file's lights, a perspective camera node first in the scene — so that an
earlier gibake without --sun and --look-at (c2145de) bakes and renders the
same light and view as today's binary with levels.json's flags. The moving
objects are left static (c2145de has no --dynamic). Standard library only.

    python3 tools/old_binaries/levels_with_flags.py OUT_DIR

writes OUT_DIR/<level folder>/<file> and OUT_DIR/list.json; measured with
in docs/results.md, "Frame cost against c2145de", "The real levels with
their flags in the file".
"""
import json, math, os, shutil, struct, sys
src = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'data', 'levels')
dst = sys.argv[1] if len(sys.argv) > 1 else 'levels-with-flags'
L = json.load(open(f'{src}/levels.json'))
def norm(v): l = math.sqrt(sum(x*x for x in v)); return [x/l for x in v]
def cross(a, b): return [a[1]*b[2]-a[2]*b[1], a[2]*b[0]-a[0]*b[2], a[0]*b[1]-a[1]*b[0]]
def quat(X, Y, Z):  # rotation matrix with columns X, Y, Z -> quaternion xyzw
    m00, m01, m02 = X[0], Y[0], Z[0]; m10, m11, m12 = X[1], Y[1], Z[1]; m20, m21, m22 = X[2], Y[2], Z[2]
    t = m00 + m11 + m22
    if t > 0:
        s = math.sqrt(t + 1) * 2; return [(m21-m12)/s, (m02-m20)/s, (m10-m01)/s, s/4]
    if m00 > m11 and m00 > m22:
        s = math.sqrt(1 + m00 - m11 - m22) * 2; return [s/4, (m01+m10)/s, (m02+m20)/s, (m21-m12)/s]
    if m11 > m22:
        s = math.sqrt(1 + m11 - m00 - m22) * 2; return [(m01+m10)/s, s/4, (m12+m21)/s, (m02-m20)/s]
    s = math.sqrt(1 + m22 - m00 - m11) * 2; return [(m02+m20)/s, (m12+m21)/s, s/4, (m10-m01)/s]
def frame(Z):
    up = [0, 1, 0] if abs(Z[1]) < 0.99 else [1, 0, 0]
    X = norm(cross(up, Z)); Y = cross(Z, X); return quat(X, Y, Z)
def edit(g, l):
    nodes = g.setdefault('nodes', [])
    for n in nodes:
        n.get('extensions', {}).pop('KHR_lights_punctual', None)
    s = l['sun']; a, e = math.radians(s['azimuth']), math.radians(s['elevation'])
    toward = [math.cos(e)*math.sin(a), math.sin(e), -math.cos(e)*math.cos(a)]
    g.setdefault('extensions', {})['KHR_lights_punctual'] = {'lights': [{'type': 'directional', 'name': 'sun', 'color': [1, 1, 1], 'intensity': s['irradiance']}]}
    c = l['camera']; eye, tgt = c['eye'], c['target']
    cams = g.setdefault('cameras', [])
    cams.insert(0, {'type': 'perspective', 'name': 'c2cam', 'perspective': {'yfov': math.radians(c['fov']), 'znear': 0.05}})
    for n in nodes:
        if 'camera' in n: n['camera'] += 1
    cam_node = {'name': 'c2cam', 'camera': 0, 'translation': eye, 'rotation': frame(norm([eye[i]-tgt[i] for i in range(3)]))}
    sun_node = {'name': 'c2sun', 'translation': [x*100 for x in toward], 'rotation': frame(norm(toward)), 'extensions': {'KHR_lights_punctual': {'light': 0}}}
    k = len(nodes); nodes += [cam_node, sun_node]
    sc = g['scenes'][g.get('scene', 0)]; sc['nodes'] = [k, k+1] + sc['nodes']
    used = g.setdefault('extensionsUsed', [])
    if 'KHR_lights_punctual' not in used: used.append('KHR_lights_punctual')
out = []
for l in L:
    if 'bake_volume' in l or l.get('time'): print('skip', l['name'], 'bake volume/time'); continue
    f = l['file']; d = os.path.dirname(f)
    shutil.rmtree(f'{dst}/{d}', ignore_errors=True); shutil.copytree(f'{src}/{d}', f'{dst}/{d}')
    p = f'{dst}/{f}'
    if p.endswith('.gltf'):
        g = json.load(open(p)); edit(g, l); json.dump(g, open(p, 'w'))
    else:
        b = open(p, 'rb').read(); n0 = struct.unpack('<I', b[12:16])[0]
        g = json.loads(b[20:20+n0]); rest = b[20+n0:]; edit(g, l)
        j = json.dumps(g).encode(); j += b' ' * ((4 - len(j) % 4) % 4)
        body = struct.pack('<I', len(j)) + b'JSON' + j + rest
        open(p, 'wb').write(b[:8] + struct.pack('<I', 12 + len(body)) + body)
    out.append({'name': l['name'], 'file': f})
json.dump(out, open(f'{dst}/list.json', 'w'), indent=1)
print(len(out), 'levels')
