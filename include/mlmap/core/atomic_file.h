#pragma once
/// @file
/// Writing an output file whole or not at all: every file a program promises (maps, exports,
/// pictures, voxel lists, JSON reports) goes through writeFileAtomically(), so a failure (disk
/// full, folder read-only, a signal) never leaves a partial file under the promised name.

#include <cstddef>
#include <string>

namespace mlmap {

/// Writes `bytes` to `path`: into a temporary file `path`.tmp-XXXXXX in the same folder, flushed
/// to disk, then renamed over `path`. When anything fails (folder missing or read-only, disk
/// full) the temporary file is removed, `path` keeps its previous content (or stays absent), and
/// std::runtime_error "cannot write '<path>': <reason>" is thrown.
/// Then removes what earlier writes of `path` killed before their rename left beside it
/// (removeLeftoverTemporaries()).
void writeFileAtomically(const std::string& path, const std::string& bytes);

/// Removes the temporary files a write of `path` left behind when it was killed before its
/// rename ("<name>.tmp-XXXXXX" beside `path`); returns how many. writeFileAtomically() calls it
/// after each write; the node calls it at start for its save path. Never throws.
std::size_t removeLeftoverTemporaries(const std::string& path);

}  // namespace mlmap
