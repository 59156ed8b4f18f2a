"""Frame sequences on a Dask cluster: one task per frame, each writing the files
``pipetile mesh 'sim/smoke.####.vdb' -o 'out/smoke.####.ply'`` writes, byte for byte.

    from distributed import Client, LocalCluster
    import pipetile.dask

    with LocalCluster(n_workers=2, threads_per_worker=1) as cluster, Client(cluster) as client:
        summary = pipetile.dask.mesh_frames(client, "sim/smoke.####.vdb", "1001-1100", "out/smoke.####.ply")

On a real cluster, ``Client("tcp://scheduler:8786")`` (or a dask-jobqueue / Kubernetes cluster)
instead: the workers must see the same paths (a shared file system) and import pipetile.
"""

import json
import os
import time
import uuid

from . import _pipetile
from ._pipetile import Error

__all__ = ["mesh_frames"]


def mesh_frames(client, pattern, frames, out_pattern, *, report=None, skip_existing=False, timeout=None,
                grid=None, iso=None, axis="auto", spacing=2.0, rays=8, levels=4, every_slice=False, threads=0,
                tiler="contour-tree"):
    """Meshes every frame of ``pattern`` (``####``, ``$F4`` or ``%04d``) on the cluster of
    ``client``, one task per frame, into ``out_pattern`` (level k to NAME_L<k>.EXT) and, with
    ``report``, a JSON report per frame (a pattern too). Returns the aggregate report, the dict
    ``pipetile mesh --summary`` writes: frames, meshed, skipped, failed, failures (each frame
    named as the CLI names it), totals and seconds.

    ``frames``: "A-B" or "A-B:STEP" as ``--frames`` takes it, a list of frame numbers, or None
    for the files that exist. ``skip_existing`` skips frames whose outputs all exist.
    ``threads``: TBB threads per task; 0 shares each host's cores among the tasks its workers run
    at once, so that workers do not oversubscribe them. ``timeout``: seconds to wait for all
    tasks (None: no limit). The other options are ``pipetile.mesh``'s.
    """
    start = time.monotonic()
    # Paths go to the module as bytes: a name that is no UTF-8 (os.fsdecode's surrogates) stays.
    pattern, out_pattern = os.fsencode(pattern), os.fsencode(out_pattern)
    report = None if report is None else os.fsencode(report)
    numbers = _frames(pattern, frames)
    for text in (out_pattern, report):
        if text is not None:
            _pipetile.frame_path(text, 0)  # a UsageError unless it holds a frame number
    options = dict(grid=os.fsencode(grid or ""), iso=iso, axis=axis, spacing=spacing, rays=rays, levels=levels,
                   every_slice=every_slice, tiler=tiler)
    shares = _thread_shares(client) if threads == 0 else None
    run = uuid.uuid4().hex
    tasks = [client.submit(_mesh_frame, frame, pattern, out_pattern, report, skip_existing, threads, shares, options,
                           key=f"pipetile-frame-{frame}-{run}")
             for frame in numbers]
    outcomes = client.gather(tasks) if timeout is None else _gather(client, tasks, timeout)
    return json.loads(_pipetile.sequence_report(pattern, out_pattern, _json(outcomes), time.monotonic() - start))


def _json(outcomes):
    """The outcomes as JSON text, which is UTF-8: a path's bytes that are no UTF-8 (kept as
    surrogates) become U+FFFD, as in the CLI's reports."""
    text = json.dumps(outcomes, ensure_ascii=False)
    return text.encode("utf-8", "surrogateescape").decode("utf-8", "replace")


def _frames(pattern, frames):
    if frames is None or isinstance(frames, str):
        return _pipetile.sequence_frames(pattern, frames or "")
    return [int(f) for f in frames]


def _thread_shares(client):
    """{host: tasks its workers run at once}, for each task's share of its host's cores."""
    shares = {}
    for address, worker in client.scheduler_info()["workers"].items():
        host = worker.get("host") or address.rsplit(":", 1)[0]
        shares[host] = shares.get(host, 0) + worker["nthreads"]
    return shares


def _gather(client, tasks, timeout):
    import distributed

    distributed.wait(tasks, timeout=timeout)
    return client.gather(tasks)


def _task_threads(threads, shares):
    """TBB threads for one task: the given number, or its host's cores over its tasks at once."""
    if threads:
        return threads
    import distributed

    worker = distributed.get_worker()
    host = worker.address.split("://")[-1].rsplit(":", 1)[0]
    cores = len(os.sched_getaffinity(0))
    return max(1, cores // max(1, shares.get(host, worker.state.nthreads)))


def _mesh_frame(frame, pattern, out_pattern, report, skip_existing, threads, shares, options):
    """One frame on a worker, as the CLI's batch meshes it; a failure is the frame's outcome."""
    source, output, report_path = (_pipetile.frame_path(p, frame) if p else "" for p in (pattern, out_pattern, report))
    outcome = {"frame": frame, "input": source}
    paths = [os.fsencode(p) for p in (source, output, report_path)]
    if skip_existing and _pipetile.outputs_exist(*paths[1:], options["levels"]):
        return dict(outcome, status="skipped")
    try:
        text, notes = _pipetile.mesh_to_files(*paths, threads=_task_threads(threads, shares), **options)
    except Error as e:
        return dict(outcome, status="failed", error=_pipetile.frame_error(frame, os.fsencode(str(e))))
    except MemoryError:
        message = (f"out of memory meshing '{source}': lower levels or rays, raise spacing, or clip the grid "
                   "to the object")
        return dict(outcome, status="failed", error=_pipetile.frame_error(frame, os.fsencode(message)))
    return dict(outcome, status="meshed", report=json.loads(text), notes=notes)

