"""Makes the environment-convention references: a smooth, asymmetric lat-long map
and Mitsuba 3's renders of it as seen directly, with and without a rotation.

Run with `pip install mitsuba numpy` (3.9.1 made the files here):
    python3 make.py
"""
import mitsuba as mi
import numpy as np

mi.set_variant('scalar_rgb')
W, H = 128, 64
# Texel centres in Mitsuba's convention: u = atan2(x, -z) / 2pi, v = acos(y) / pi.
u = (np.arange(W) + 0.5) / W
v = (np.arange(H) + 0.5) / H
phi, theta = np.meshgrid(2 * np.pi * u, np.pi * v)
x, y, z = np.sin(theta) * np.sin(phi), np.cos(theta), -np.sin(theta) * np.cos(phi)
# Every direction gets its own colour, so a turned or mirrored map cannot match.
sky = np.stack([0.6 + 0.5 * x, 0.6 + 0.5 * y, 0.6 + 0.5 * z], axis=-1).astype(np.float32)
mi.Bitmap(sky).write('sky.exr')

T = mi.ScalarTransform4f
for name, to_world in [('identity', T()), ('rotate-90', T().rotate([0, 1, 0], 90))]:
    for view, look in [('front', '0,0,-1'), ('side', '1,0.3,0')]:
        target = [float(c) for c in look.split(',')]
        scene = mi.load_dict({
            'type': 'scene',
            'integrator': {'type': 'path', 'max_depth': 1},
            'env': {'type': 'envmap', 'filename': 'sky.exr', 'to_world': to_world},
            'sensor': {
                'type': 'perspective', 'fov': 60, 'fov_axis': 'y',
                'to_world': T().look_at(origin=[0, 0, 0], target=target, up=[0, 1, 0]),
                'film': {'type': 'hdrfilm', 'width': 48, 'height': 32,
                         'rfilter': {'type': 'box'}},
                'sampler': {'type': 'independent', 'sample_count': 64},
            },
        })
        mi.util.write_bitmap(f'mitsuba-{name}-{view}.exr', mi.render(scene))
