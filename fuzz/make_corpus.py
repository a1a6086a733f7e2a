#!/usr/bin/env python3
"""fuzz/make_corpus.py: writes the seed corpora under fuzz/corpus/<name>/ (small: the whole corpus
stays well under 2 MB). Scenes, meshes and textures come from scenes/; the rest is generated here:
XML scenes that reach every plugin family and dialect, meshes in every OBJ/PLY/.serialized variant,
and, with the `specula` binary given, an EXR with variance and AOV channels and a checkpoint.

usage: python3 fuzz/make_corpus.py [path/to/specula]
"""
import os, shutil, struct, subprocess, sys, tempfile, zlib

root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
corpus = os.path.join(root, 'fuzz', 'corpus')


def put(name, fname, data):
    d = os.path.join(corpus, name)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, fname), 'wb') as f:
        f.write(data if isinstance(data, bytes) else data.encode())


def copy(name, src):
    put(name, os.path.basename(src), open(os.path.join(root, src), 'rb').read())


# ---- XML ----
copy('xml', 'scenes/demo.xml')
copy('xml', 'scenes/shapes.xml')
SENSOR = '''<sensor type="perspective"><float name="fov" value="45"/>
 <transform name="to_world"><lookat origin="0,0,5" target="0,0,0" up="0,1,0"/></transform>
 <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
 <film type="hdrfilm"><integer name="width" value="$res"/><integer name="height" value="$res"/>
 <rfilter type="gaussian"><float name="stddev" value="0.4"/></rfilter></film></sensor>'''
put('xml', 'bsdfs.xml', f'''<?xml version="1.0"?>
<scene version="3.0.0"><default name="spp" value="1"/><default name="res" value="4"/>
<integrator type="path"><integer name="max_depth" value="5"/><integer name="rr_depth" value="3"/></integrator>
{SENSOR}
<texture type="checkerboard" id="chk"><rgb name="color0" value="0.1"/><rgb name="color1" value="0.8,0.2,0.1"/>
 <transform name="to_uv"><scale x="4" y="4"/></transform></texture>
<bsdf type="roughconductor" id="rc"><string name="material" value="Au"/><float name="alpha" value="0.2"/>
 <string name="distribution" value="beckmann"/></bsdf>
<bsdf type="roughdielectric" id="rd"><float name="int_ior" value="1.5"/><float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.3"/></bsdf>
<bsdf type="plastic" id="pl"><rgb name="diffuse_reflectance" value="0.2,0.4,0.6"/></bsdf>
<bsdf type="roughplastic" id="rp"><ref name="diffuse_reflectance" id="chk"/></bsdf>
<bsdf type="blendbsdf" id="bl"><float name="weight" value="0.3"/><ref id="rc"/><ref id="pl"/></bsdf>
<bsdf type="mask" id="mk"><float name="opacity" value="0.5"/><bsdf type="diffuse"/></bsdf>
<bsdf type="twosided" id="ts"><bsdf type="roughdiffuse"><float name="alpha" value="0.5"/></bsdf></bsdf>
<bsdf type="thindielectric" id="td"/>
<bsdf type="phong" id="ph"><float name="exponent" value="20"/></bsdf>
<shape type="sphere"><float name="radius" value="0.5"/><ref id="rc"/></shape>
<shape type="sphere"><point name="center" x="1" y="0" z="0"/><float name="radius" value="0.3"/><ref id="rd"/></shape>
<shape type="rectangle"><transform name="to_world"><scale value="3"/><translate z="-1"/></transform><ref id="bl"/></shape>
<shape type="disk"><transform name="to_world"><rotate x="1" angle="90"/><translate y="-1"/></transform><ref id="mk"/></shape>
<shape type="cube"><transform name="to_world"><scale value="0.2"/><translate x="-1"/></transform><ref id="ts"/></shape>
<shape type="cylinder"><float name="radius" value="0.1"/><point name="p0" x="0" y="-1" z="0"/><point name="p1" x="0" y="1" z="0"/><ref id="ph"/></shape>
<shape type="rectangle"><transform name="to_world"><translate y="2"/></transform><ref id="td"/>
 <emitter type="area"><rgb name="radiance" value="5"/></emitter></shape>
<emitter type="point"><point name="position" x="0" y="3" z="0"/><rgb name="intensity" value="10"/></emitter>
<emitter type="spot"><transform name="to_world"><lookat origin="0,3,3" target="0,0,0"/></transform><float name="cutoff_angle" value="30"/></emitter>
<emitter type="directional"><vector name="direction" x="0" y="-1" z="0"/><rgb name="irradiance" value="1"/></emitter>
<emitter type="constant"><rgb name="radiance" value="0.1"/></emitter>
</scene>''')
put('xml', 'old_dialect.xml', '''<?xml version="1.0"?>
<scene version="0.5.0">
<integrator type="path"><integer name="maxDepth" value="3"/></integrator>
<sensor type="perspective"><float name="fov" value="40"/><string name="fovAxis" value="smaller"/>
 <transform name="toWorld"><lookAt origin="0,1,4" target="0,1,0" up="0,1,0"/></transform>
 <sampler type="ldsampler"><integer name="sampleCount" value="2"/></sampler>
 <film type="ldrfilm"><integer name="width" value="6"/><integer name="height" value="4"/>
 <integer name="cropOffsetX" value="1"/><integer name="cropWidth" value="3"/></film></sensor>
<bsdf type="diffuse" id="w"><srgb name="reflectance" value="#c0c0c0"/></bsdf>
<bsdf type="dielectric" id="g"><string name="intIOR" value="bk7"/><string name="extIOR" value="air"/></bsdf>
<shape type="cube"><ref id="w"/></shape>
<shape type="sphere"><point name="center" x="0" y="1" z="0"/><float name="radius" value="0.5"/><ref id="g"/></shape>
<shape type="rectangle"><transform name="toWorld"><matrix value="1 0 0 0 0 1 0 2 0 0 1 0 0 0 0 1"/></transform>
 <emitter type="area"><spectrum name="radiance" value="10"/></emitter></shape>
<emitter type="constant"><spectrum name="radiance" value="400:0.1, 700:0.2"/></emitter>
</scene>''')
put('xml', 'files.xml', '''<?xml version="1.0"?>
<scene version="3.0.0"><include filename="other.xml"/>
<emitter type="envmap"><string name="filename" value="sky.exr"/></emitter>
<shape type="obj"><string name="filename" value="m.obj"/></shape></scene>''')
put('xml', 'textures.xml', f'''<?xml version="1.0"?>
<scene version="2.1.0"><default name="spp" value="1"/><default name="res" value="4"/><default name="r" value="0.25"/>
{SENSOR}
<texture type="checkerboard" id="img"><transform name="to_uv"><translate x="0.5"/></transform></texture>
<bsdf type="diffuse" id="nm"><ref name="reflectance" id="img"/></bsdf>
<bsdf type="bumpmap" id="bm"><texture type="checkerboard"/><float name="scale" value="0.1"/><bsdf type="conductor"/></bsdf>
<shape type="sphere" id="s1"><float name="radius" value="$r"/><ref id="nm"/>
 <transform name="to_world"><rotate y="1" angle="30"/><scale x="2" y="1" z="1"/><translate value="0 0 1"/></transform></shape>
<shape type="cube"><boolean name="face_normals" value="true"/><ref id="bm"/></shape>
<shape type="sphere"><float name="radius" value="1e-3"/><emitter type="area"><texture type="checkerboard" name="radiance"/>
 </emitter></shape>
</scene>''')
put('xml', 'refs_and_errors.xml', '''<?xml version="1.0" encoding="utf-8"?>
<!DOCTYPE scene>
<scene version="3.0.0">
<default name="integrator" value="ipt"/>
<integrator type="$integrator"><boolean name="hide_emitters" value="false"/></integrator>
<sensor type="orthographic"><transform name="to_world"><scale x="2"/></transform>
 <film type="hdrfilm"><integer name="width" value="3"/><integer name="height" value="3"/><rfilter type="tent"/></film></sensor>
<bsdf type="diffuse" id="a"><rgb name="reflectance" value="0.5, 0.5, 0.5"/></bsdf>
<shape type="sphere"><ref name="bsdf" id="a"/><float name="radius" value="-1"/></shape>
<shape type="sphere"><ref id="later"/></shape>
<bsdf type="diffuse" id="later"/>
<shape type="instance"><ref id="group"/></shape>
<!-- comment &amp; entity &#x41; -->
<![CDATA[ raw ]]>
</scene>''')

# ---- OBJ ----
copy('obj', 'scenes/meshes/quad.obj')
put('obj', 'corners.obj', '''# every face syntax
o thing
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0 1.0
v 0.5 0.5 1 0.2 0.3 0.4
vt 0 0
vt 1 0
vt 1 1 0
vn 0 0 1
vn 0 0.7071 0.7071
g group
usemtl m
s 1
f 1 2 3
f 1/1 2/2 3/3
f 1//1 2//1 3//2
f 1/1/1 2/2/1 3/3/2 4/1/1
f -1 -2 -3
f 1 2 3 4 5
l 1 2
p 3
mtllib x.mtl
# concave pentagon
v 0 0 2
v 2 0 2
v 2 2 2
v 1 0.5 2
v 0 2 2
f 6 7 8 9 10
''')
ico = open(os.path.join(root, 'scenes/meshes/icosphere.obj')).read().splitlines()
put('obj', 'icosphere_head.obj', '\n'.join(l for l in ico if l.startswith('v ') or l.startswith('vn '))[:3000] + '\n' +
    '\n'.join(l for l in ico if l.startswith('f '))[:1500] + '\n')

# ---- PLY ----
def ply(fmt, normals=True, uv=True, idxtype='uint', counttype='uchar', extra=False):
    verts = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
    props = ['x', 'y', 'z'] + (['nx', 'ny', 'nz'] if normals else []) + (['u', 'v'] if uv else [])
    head = 'ply\nformat %s 1.0\ncomment fuzz seed\nelement vertex 4\n' % fmt
    head += ''.join('property float %s\n' % p for p in props)
    if extra:
        head += 'property uchar red\n'
    head += 'element face 2\nproperty list %s %s vertex_indices\n' % (counttype, idxtype)
    if extra:
        head += 'element edge 1\nproperty int vertex1\nproperty int vertex2\n'
    head += 'end_header\n'
    rows = []
    for (x, y, z) in verts:
        r = [x, y, z] + ([0, 0, 1] if normals else []) + ([x, y] if uv else [])
        rows.append(r)
    faces = [[0, 1, 2, 3], [0, 2, 3]]
    if fmt == 'ascii':
        body = ''.join(' '.join(str(v) for v in r) + (' 255' if extra else '') + '\n' for r in rows)
        body += ''.join('%d %s\n' % (len(f), ' '.join(map(str, f))) for f in faces)
        if extra:
            body += '0 1\n'
        return (head + body).encode()
    e = '<' if 'little' in fmt else '>'
    ic = {'uint': 'I', 'int': 'i', 'ushort': 'H', 'uchar': 'B'}[idxtype]
    cc = {'uchar': 'B', 'ushort': 'H', 'uint': 'I'}[counttype]
    body = b''
    for r in rows:
        body += struct.pack(e + 'f' * len(r), *r) + (b'\xff' if extra else b'')
    for f in faces:
        body += struct.pack(e + cc, len(f)) + struct.pack(e + ic * len(f), *f)
    if extra:
        body += struct.pack(e + 'ii', 0, 1)
    return head.encode() + body

put('ply', 'quad_ascii.ply', ply('ascii', extra=True))
put('ply', 'quad_le.ply', ply('binary_little_endian'))
put('ply', 'quad_be.ply', ply('binary_big_endian', normals=False, idxtype='int', counttype='uint'))
put('ply', 'quad_le_short.ply', ply('binary_little_endian', uv=False, idxtype='ushort', extra=True))
put('ply', 'torus_head.ply', open(os.path.join(root, 'scenes/meshes/torus_ascii.ply'), 'rb').read()[:2500])

# ---- .serialized ----
def serialized_mesh(version, flags, shift=0.0):
    dbl = bool(flags & 0x2000)
    real = (lambda v: struct.pack('<d', v)) if dbl else (lambda v: struct.pack('<f', v))
    raw = struct.pack('<I', flags) + (b'quad\0' if version == 4 else b'') + struct.pack('<QQ', 4, 2)
    pos = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
    for p in pos:
        raw += b''.join(real(c + (shift if k == 2 else 0)) for k, c in enumerate(p))
    if flags & 0x1:
        raw += b''.join(real(c) for _ in pos for c in (0, 0, 1))
    if flags & 0x2:
        raw += b''.join(real(c) for p in pos for c in (p[0] * 0.5, p[1] * 0.25))
    if flags & 0x8:
        raw += b''.join(real(0.3) for _ in range(12))
    raw += struct.pack('<6I', 0, 1, 2, 0, 2, 3)
    return struct.pack('<HH', 0x041C, version) + zlib.compress(raw, 6)

copy('serialized', 'scenes/meshes/cone_prism.serialized')
put('serialized', 'v3_plain.serialized', serialized_mesh(3, 0x1000))
put('serialized', 'v4_all.serialized', serialized_mesh(4, 0x1000 | 0x1 | 0x2 | 0x8))
put('serialized', 'v4_double.serialized', serialized_mesh(4, 0x2000 | 0x1))
# a dictionary of two meshes: offsets then the count at the end
a, b = serialized_mesh(4, 0x1000), serialized_mesh(4, 0x1000 | 0x2, 10.0)
put('serialized', 'v4_two.serialized', a + b + struct.pack('<QQI', 0, len(a), 2))

# ---- images ----
for f in ['emit.exr', 'ramp.exr']:
    copy('exr', 'scenes/textures/' + f)
for f in ['bumps.png', 'grid.png', 'mask.png', 'emit.png', 'blobs.jpg']:
    copy('png', 'scenes/textures/' + f)


# BMP (read by the image fuzzer through its magic bytes): 24-bit bottom-up, 4-bit palette top-down
def bmp(w, h, bpp):
    row = ((w * bpp + 31) // 32) * 4
    pal = b''.join(bytes([i * 16, 255 - i * 16, i * 8, 0]) for i in range(16)) if bpp == 4 else b''
    data = b''
    for y in range(h):
        r = bytearray(row)
        for x in range(w):
            if bpp == 24:
                r[3 * x:3 * x + 3] = bytes([(x * 40) % 256, (y * 80) % 256, (x * y * 30) % 256])
            else:
                r[x // 2] |= ((x + y) % 16) << (4 if x % 2 == 0 else 0)
        data += bytes(r)
    hdr = struct.pack('<IiiHHIIiiII', 40, w, h if bpp == 24 else -h, 1, bpp, 0, len(data), 2835, 2835,
                      16 if bpp == 4 else 0, 0)
    off = 14 + 40 + len(pal)
    return b'BM' + struct.pack('<IHHI', off + len(data), 0, 0, off) + hdr + pal + data


put('png', 'tiny24.bmp', bmp(7, 5, 24))
put('png', 'tiny4.bmp', bmp(9, 4, 4))

# ---- JPEG (the reader's own corpus): the scenes' texture, and small baseline RGB, gray and
# low-quality files written by Mitsuba 3 (the reference peer, installed beside specula) ----
copy('jpeg', 'scenes/textures/blobs.jpg')
try:
    import mitsuba as mi, numpy as np
    mi.set_variant('scalar_rgb')
    rng = np.random.default_rng(1)
    for fname, shape, fmt, q in [('rgb.jpg', (6, 8, 3), mi.Bitmap.PixelFormat.RGB, 80),
                                 ('gray.jpg', (5, 7, 1), mi.Bitmap.PixelFormat.Y, 50),
                                 ('low.jpg', (3, 16, 3), mi.Bitmap.PixelFormat.RGB, 10)]:
        b = mi.Bitmap(rng.random(shape).astype(np.float32), pixel_format=fmt)
        b = b.convert(fmt, mi.Struct.Type.UInt8, True)
        with tempfile.TemporaryDirectory() as t:
            b.write(os.path.join(t, fname), mi.Bitmap.FileFormat.JPEG, q)
            put('jpeg', fname, open(os.path.join(t, fname), 'rb').read())
except ImportError:
    print('mitsuba not installed: only blobs.jpg in the JPEG corpus', file=sys.stderr)

# ---- the command line's numbers (fuzz_cli): arguments separated by NUL bytes ----
put('cli', 'numbers', '\0'.join(['16x16', '1,2', '4294967312x4294967312', '0.5', '-1', '18446744073709551615',
                                  '1e308', 'nan', 'angular:biased=8,trials=64']) + '\0')
put('cli', 'options', '\0'.join(['newton:constraint=half,rough,chain=3,mispsi=0.1,receivers=2',
                                  'conic:reflect=0.2,camera=0.25,long=0.1,guide=2,sneep=0.5', ' 7', '+3', '0x10',
                                  '65536x65536']) + '\0')

# ---- with the binary: a multi-channel EXR and a checkpoint ----
if len(sys.argv) > 1:
    exe = os.path.abspath(sys.argv[1])
    with tempfile.TemporaryDirectory() as t:
        subprocess.run([exe, 'render', os.path.join(root, 'scenes/demo.xml'), '-D', 'res=4', '--spp', '4',
                        '--variance', '--aovs', '--quiet', '-o', os.path.join(t, 'aov.exr'),
                        '--checkpoint', os.path.join(t, 'c.ckpt')], check=True)
        put('exr', 'aov.exr', open(os.path.join(t, 'aov.exr'), 'rb').read())
        put('checkpoint', 'aov.ckpt', open(os.path.join(t, 'c.ckpt'), 'rb').read())
        subprocess.run([exe, 'render', os.path.join(root, 'scenes/demo.xml'), '-D', 'res=3', '--spp', '2',
                        '--quiet', '-o', os.path.join(t, 'p.exr'), '--checkpoint', os.path.join(t, 'p.ckpt')],
                       check=True)
        put('checkpoint', 'plain.ckpt', open(os.path.join(t, 'p.ckpt'), 'rb').read())
        put('png', 'render.png', open(os.path.join(t, 'p.png'), 'rb').read())
