#!/usr/bin/env python3
"""Random crops of Gaffer's smoke, meshed along x, y and z: does every level have the Euler
characteristic and components of volumeToMesh's isosurface of the same crop?

    python3 tools/crop_survey.py SEED RUNS [PIPETILE]     # PIPETILE: build/pipetile by default
    python3 tools/crop_survey.py SEED RUNS [PIPETILE] --validate
    python3 tools/crop_survey.py SEED RUNS [PIPETILE] [--validate] --data FILE [--iso V]

Each run draws a box 20 to 50 voxels a side inside the smoke's active box and an isovalue of 0.1,
0.2 or 0.3, writes the crop (pyopenvdb), meshes it with `--levels 2` along each axis, and compares
each level's topology (the report's) with the isosurface's (pyopenvdb's volumeToMesh, adaptivity
0, welded). Prints the runs that differ and the count that match; the README's crop counts come
from seeds 101 to 110 with 15 runs each, 12 for seed 103.

With --validate, each run meshes 4 levels with `--validate`: every level must also be closed,
manifold and oriented, and the runs whose top level is more than a voxel from the isosurface
(symmetric Hausdorff distance) are printed with that distance, and the runs with a triangle of
aspect ratio over 100 at some level (issue 17's bound) with each level's largest; the README's
"fresh survey" is seeds 106 to 110 with 15 runs each.

With --data FILE, the crops are of that grid instead; a level set's (such as
../shared/data/real/vmtk_aorta_ls.vdb) are 20 to 60 voxels a side, at its zero level, and what
lies outside the box is the background, so the box cuts the object square. With --iso V every run
uses the isovalue V: a fog volume whose values are not densities needs it (the cone vessel's
intensities, ../shared/data/real/cip_cone_vessel_density.vdb, at -500). Debian's python3 with
python3-openvdb and python3-numpy (tools/dev.sh installs both)."""
import json
import os
import random
import subprocess
import sys
import tempfile

import numpy as np
import pyopenvdb as vdb

HERE = os.path.dirname(os.path.abspath(__file__))
SMOKE = os.path.join(HERE, '..', '..', 'shared', 'data', 'real', 'gaffer_smoke_fog.vdb')


def topology(points, faces):
    """Euler characteristic and components of a welded triangle mesh."""
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    edges = np.unique(edges, axis=0)
    used = np.unique(faces)
    parent = np.arange(len(points))

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    for a, b in edges:
        ra, rb = find(a), find(b)
        if ra != rb:
            parent[max(ra, rb)] = min(ra, rb)
    return len(used) - len(edges) + len(faces), len({find(v) for v in used})


def main():
    validate = '--validate' in sys.argv
    args = [a for a in sys.argv[1:] if a != '--validate']
    data = SMOKE
    if '--data' in args:
        data = args.pop(args.index('--data') + 1)
        args.remove('--data')
    fixed_iso = None
    if '--iso' in args:
        fixed_iso = float(args.pop(args.index('--iso') + 1))
        args.remove('--iso')
    seed, runs = int(args[0]), int(args[1])
    exe = args[2] if len(args) > 2 else os.path.join(HERE, '..', 'build', 'pipetile')
    levels_wanted = ['--levels', '4', '--validate'] if validate else ['--levels', '2']
    distances = []
    grid = vdb.read(data, vdb.readAllGridMetadata(data)[0].name)
    level_set = grid.gridClass == 'level set'
    lo, hi = grid.evalActiveVoxelBoundingBox()
    rng = random.Random(seed)
    matched = total = needles = 0
    with tempfile.TemporaryDirectory() as work:
        for run in range(runs):
            size = [rng.randint(20, 60 if level_set else 50) for _ in range(3)]
            a = [rng.randint(lo[k], max(lo[k], hi[k] - size[k])) for k in range(3)]
            b = [a[k] + size[k] for k in range(3)]
            iso = 0.0 if level_set else rng.choice([0.1, 0.2, 0.3])
            iso = iso if fixed_iso is None else fixed_iso
            # A level set's inside beyond its narrow band is inactive at minus the background.
            values = np.full([b[k] - a[k] + 1 for k in range(3)], grid.background, np.float32)
            grid.copyToArray(values, ijk=tuple(a))
            crop = vdb.FloatGrid(grid.background)
            crop.copyFromArray(values, ijk=tuple(a), tolerance=0.0)
            crop.transform = grid.transform
            crop.gridClass = grid.gridClass
            crop.name = 'density'
            path = os.path.join(work, 'crop.vdb')
            vdb.write(path, grids=[crop])
            points, triangles, quads = crop.convertToPolygons(isovalue=iso, adaptivity=0.0)
            faces = np.concatenate([triangles.reshape(-1, 3), quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]]).astype(np.int64)
            box = f'{",".join(map(str, a))}..{",".join(map(str, b))} iso {iso}'
            if len(faces) == 0:
                print(f'run {run} {box}: the isovalue crosses nothing')
                continue
            reference = topology(points, faces)
            for axis in 'xyz':
                report = os.path.join(work, 'report.json')
                result = subprocess.run([exe, 'mesh', path, '--iso', str(iso), '--axis', axis, *levels_wanted,
                                         '-o', os.path.join(work, 'mesh.ply'), '--report', report],
                                        capture_output=True, text=True)
                total += 1
                if result.returncode != 0:
                    print(f'run {run} {box} {axis}: exit {result.returncode}: {result.stderr.strip()}')
                    continue
                reported = json.load(open(report))['levels']
                levels = [(level['euler'], level['components']) for level in reported]
                sound = all(level['validation'][k] for level in reported if validate
                            for k in ('closed', 'manifold', 'oriented'))
                if all(level == reference for level in levels) and sound:
                    matched += 1
                else:
                    print(f'run {run} {box} {axis}: isosurface {reference}, levels {levels}, '
                          f'closed manifold oriented {sound} {result.stderr.strip()}')
                if validate:
                    distances.append(reported[-1]['validation']['hausdorff_voxels'])
                    if distances[-1] > 1:
                        print(f'run {run} {box} {axis}: top level {distances[-1]:.2f} voxels off')
                    aspects = [level['largest_aspect'] for level in reported]
                    if max(aspects) > 100:
                        needles += 1
                        print(f'run {run} {box} {axis}: largest aspect ratio per level '
                              f'{", ".join(f"{a:.1f}" for a in aspects)}')
    print(f'seed {seed}: {matched} of {total} runs match')
    if validate:
        print(f'seed {seed}: {sum(d > 1 for d in distances)} of {len(distances)} runs more than a voxel off '
              f'at the top level, mean {np.mean(distances):.3f} voxel; {needles} with a triangle of aspect '
              f'ratio over 100 at some level')


if __name__ == '__main__':
    main()
