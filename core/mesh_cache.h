// A binary copy of what read_mesh makes of a mesh file, kept beside the file (<file>.cache), so that the commands
// that read an avatar folder again and again (makeup apply, relight, viewer) take milliseconds for its 65k-vertex
// mesh.obj instead of the OBJ reader's second. The copy names the file's size and hash, the reader version and a
// checksum of its own bytes: a changed file, a copy from another reader version, a truncated or corrupt copy are
// all ignored (the file is read and the copy written anew), so the result is read_mesh's, bit for bit, or an error
// of read_mesh's. docs/file_formats.md, "Mesh cache".
#pragma once
#include <string>

#include "core/mesh.h"

namespace bareskin {

enum class MeshCacheUse {
  kHit,         // the mesh came from the cache
  kWritten,     // read from the file; the cache was (re)written
  kNotWritten,  // read from the file; no cache could be written (a read-only folder, a full disk, the file changed)
};

// The cache of `path`: path + ".cache".
std::string mesh_cache_path(const std::string& path);

// read_mesh(path), from the cache when it holds this very file's mesh; otherwise read_mesh(path), and the cache
// written beside it where that can be done (a failure to write is logged at debug level, never an error). Throws
// what read_mesh throws. `use`, when given, says which of the three happened.
Mesh read_mesh_cached(const std::string& path, MeshCacheUse* use = nullptr);

}  // namespace bareskin
