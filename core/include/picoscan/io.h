// Reading and writing clouds and meshes: PLY (ASCII/binary), STL (ASCII/binary), OBJ.
// Every writer goes through a temporary file in the same folder and a rename, so a
// failure leaves no half-written output. Readers throw Error naming the file.
#pragma once

#include "picoscan/cloud.h"
#include "picoscan/progress.h"

#include <string>
#include <vector>

namespace picoscan {

enum class Encoding { Binary, Ascii };

void write_ply(const PointCloud& cloud, const std::string& path, Encoding encoding = Encoding::Binary);
void write_ply(const Mesh& mesh, const std::string& path, Encoding encoding = Encoding::Binary);
void write_stl(const Mesh& mesh, const std::string& path, Encoding encoding = Encoding::Binary);
void write_obj(const Mesh& mesh, const std::string& path);
// 3MF for printing: one mesh object, units millimetres (lib3mf).
void write_3mf(const Mesh& mesh, const std::string& path);
// Any writer by extension (.stl, .ply with colours and quality, .obj, .3mf; the encoding applies
// to STL and PLY); throws Error naming the file for another extension.
void write_mesh(const Mesh& mesh, const std::string& path, Encoding encoding = Encoding::Binary);

// The readers of PLY and STL report the share of records read (stage "reading the mesh") and hear
// Cancel: answering false stops them (Error("cancelled", ...)).
// PLY with or without faces (a point cloud reads as a Mesh with no faces).
Mesh read_ply(const std::string& path, const ProgressCallback& progress = {});
// STL, binary or ASCII (detected); vertices are merged where exactly equal.
Mesh read_stl(const std::string& path, const ProgressCallback& progress = {});
// 3MF: every mesh object's triangles, converted to millimetres from the file's unit.
Mesh read_3mf(const std::string& path);
// Any of the above by extension (.ply, .stl, .3mf; 3MF reports only its end).
Mesh read_mesh(const std::string& path, const ProgressCallback& progress = {});

// A view's valid points with their camera pixel kept (vertex property "pixel" = y * width + x,
// and the comments "picoscan_grid W H" and "picoscan_pose" + 16 numbers), so that the
// organised view, and the features of its white frame, come back on reading.
void write_view_ply(const ScanView& view, const std::string& path, Encoding encoding = Encoding::Binary);
// Throws Error naming the file when it has no pixel grid (not written by write_view_ply).
ScanView read_view_ply(const std::string& path);

// A poses file (docs/formats.md): per view a line with its name (followed by NOT-ALIGNED when
// it was not aligned), then its view -> model pose as 4 rows of 4 numbers; '#' lines are comments.
struct ViewPose {
    std::string name;
    cv::Matx44d pose = cv::Matx44d::eye();
    bool aligned = true;
    int placement = 0;  // which placement of the part the view belongs to (0: the first); a '# placement N' line
};
void write_poses(const std::vector<ViewPose>& poses, const std::string& path);
// Throws Error naming the file and the line when it is malformed.
std::vector<ViewPose> read_poses(const std::string& path);

}  // namespace picoscan
