#pragma once
/// @file
/// Writing an output file whole or not at all: every file a program promises (maps, exports,
/// pictures, voxel lists, JSON reports) goes through writeFileAtomically(), so a failure (disk
/// full, folder read-only, a signal) never leaves a partial file under the promised name.

#include <string>

namespace mlmap::io {

/// Writes `bytes` to `path`: into a temporary file `path`.tmp-XXXXXX in the same folder, flushed
/// to disk, then renamed over `path`. When anything fails (folder missing or read-only, disk
/// full) the temporary file is removed, `path` keeps its previous content (or stays absent), and
/// std::runtime_error "cannot write '<path>': <reason>" is thrown.
void writeFileAtomically(const std::string& path, const std::string& bytes);

}  // namespace mlmap::io
