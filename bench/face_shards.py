"""Reading `texgen faces` splits from Python benches: each sample's members and metadata, PNGs area-resized."""
import glob
import io
import json
import sys
import tarfile

import numpy as np
from PIL import Image


def split_samples(faces, split, tool):
    """Yields (key, open tar, metadata) for every sample of <faces>/<split>; exits with one line when there is none."""
    shards = sorted(glob.glob(f"{faces}/{split}/*.tar"))
    if not shards:
        sys.exit(f"{tool}: no shards in {faces}/{split}; give a `texgen faces` output folder")
    for shard in shards:
        with tarfile.open(shard) as t:
            for name in sorted(n for n in t.getnames() if n.endswith(".json")):
                yield name[:-5], t, json.loads(t.extractfile(name).read())


def png(data, size):
    """A PNG's pixels in [0, 1], area-resized to size² (its side a multiple of size)."""
    a = np.asarray(Image.open(io.BytesIO(data)), np.float64) / 255
    f = a.shape[0] // size
    return a.reshape(size, f, size, f, *a.shape[2:]).mean((1, 3))


def whole_footprint(mask):
    """The pixels of an area-resized mask whose whole footprint lay in it (as `train bareskin`'s metrics take them):
    on the face's outline a resized pixel is part hair or background, and the bare truth, black off the face, is
    darkened there."""
    return mask >= 0.999


def member(t, key, name, size):
    """Sample key's <name>.png from tar t, area-resized to size²."""
    return png(t.extractfile(f"{key}.{name}.png").read(), size)
