// Reading and writing clouds and meshes: PLY (ASCII/binary), STL (ASCII/binary), OBJ.
// Every writer goes through a temporary file in the same folder and a rename, so a
// failure leaves no half-written output. Readers throw Error naming the file.
#pragma once

#include "picoscan/cloud.h"

#include <string>

namespace picoscan {

enum class Encoding { Binary, Ascii };

void write_ply(const PointCloud& cloud, const std::string& path, Encoding encoding = Encoding::Binary);
void write_ply(const Mesh& mesh, const std::string& path, Encoding encoding = Encoding::Binary);
void write_stl(const Mesh& mesh, const std::string& path, Encoding encoding = Encoding::Binary);
void write_obj(const Mesh& mesh, const std::string& path);

// PLY with or without faces (a point cloud reads as a Mesh with no faces).
Mesh read_ply(const std::string& path);
// STL, binary or ASCII (detected); vertices are merged where exactly equal.
Mesh read_stl(const std::string& path);
// Any of the above by extension (.ply, .stl).
Mesh read_mesh(const std::string& path);

// A view's valid points with their camera pixel kept (vertex property "pixel" = y * width + x,
// and the comments "picoscan_grid W H" and "picoscan_pose" + 16 numbers), so that the
// organised view, and the features of its white frame, come back on reading.
void write_view_ply(const ScanView& view, const std::string& path, Encoding encoding = Encoding::Binary);
// Throws Error naming the file when it has no pixel grid (not written by write_view_ply).
ScanView read_view_ply(const std::string& path);

// Writes `bytes` to `path` through a temporary file and a rename. Temporary files are
// removed on failure and, unless the host handles these signals itself, on SIGINT, SIGTERM
// and SIGHUP.
void write_file_atomically(const std::string& path, const std::string& bytes);

// The outputs of one command, replaced together. While a batch is alive, every write
// through write_file_atomically (from any thread) stays in its temporary file; commit()
// renames them all into place. A batch destroyed without commit() (an error on the way)
// removes the temporary files, so the old outputs stay whole. One batch at a time.
class OutputBatch {
public:
    OutputBatch();
    ~OutputBatch();
    OutputBatch(const OutputBatch&) = delete;
    OutputBatch& operator=(const OutputBatch&) = delete;
    void commit();
};

}  // namespace picoscan
