"""Independent reader of our shards: Python's tarfile, grouping members into samples by key the way the webdataset
package does (key = the path up to the first dot of the file name; a new key starts a new sample).
    python3 webdataset_oracle.py SHARD.tar  ->  one line per sample: key, then suffix=crc32 of each member, sorted
"""
import sys
import tarfile
import zlib


def samples(path):
    current, members = None, {}
    with tarfile.open(path, "r:") as tar:
        for info in tar:
            if not info.isfile():
                continue
            slash = info.name.rfind("/")
            dot = info.name.find(".", slash + 1)
            key, suffix = info.name[:dot], info.name[dot + 1:]
            if key != current and current is not None:
                yield current, members
                members = {}
            current = key
            members[suffix] = tar.extractfile(info).read()
    if current is not None:
        yield current, members


for key, members in samples(sys.argv[1]):
    print(key, " ".join(f"{s}={zlib.crc32(b):08x}" for s, b in sorted(members.items())))
