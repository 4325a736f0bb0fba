// Poses files: the view -> model pose of each view, as stitch writes them and reads them back.
#include "io/io_detail.h"
#include "picoscan/error.h"
#include "picoscan/file_output.h"
#include "picoscan/io.h"

#include <cmath>
#include <sstream>

namespace picoscan {

namespace {

constexpr size_t kMaxPosesFileBytes = 16u << 20;  // thousands of views are a few hundred KB
constexpr const char* kNotAligned = " NOT-ALIGNED";

}  // namespace

void write_poses(const std::vector<ViewPose>& poses, const std::string& path) {
    std::string text = "# PicoScan view -> model poses (4x4, row by row); model frame = first view's camera\n";
    for (const ViewPose& view : poses) {
        if (view.name.empty() || view.name.find('\n') != std::string::npos || view.name[0] == '#')
            throw Error(path, "view name '" + view.name + "' cannot be written in a poses file");
        text += view.name + (view.aligned ? "" : kNotAligned) + "\n";
        for (int r = 0; r < 4; ++r) {
            for (int c = 0; c < 4; ++c) {
                if (c) text += ' ';
                detail::append_number(text, view.pose(r, c));
            }
            text += '\n';
        }
    }
    write_file_atomically(path, text);
}

std::vector<ViewPose> read_poses(const std::string& path) {
    const std::string text = detail::read_whole_file(path);
    if (text.size() > kMaxPosesFileBytes) throw Error(path, "is larger than a poses file can be (16 MB)");
    std::stringstream lines(text);
    std::vector<ViewPose> poses;
    std::string line;
    int line_number = 0;
    auto where = [&] { return path + ":" + std::to_string(line_number); };
    while (std::getline(lines, line)) {
        ++line_number;
        if (line.empty() || line[0] == '#') continue;
        ViewPose view;
        view.name = line;
        const size_t suffix = line.size() >= std::char_traits<char>::length(kNotAligned)
                                  ? line.size() - std::char_traits<char>::length(kNotAligned)
                                  : std::string::npos;
        if (suffix != std::string::npos && line.compare(suffix, std::string::npos, kNotAligned) == 0) {
            view.name = line.substr(0, suffix);
            view.aligned = false;
        }
        for (int r = 0; r < 4; ++r) {
            ++line_number;
            if (!std::getline(lines, line)) throw Error(where(), "ends inside a pose (4 rows of 4 numbers per view)");
            std::stringstream row(line);
            std::string word;
            for (int c = 0; c < 4; ++c)
                if (!(row >> word) || !detail::parse_double(word, view.pose(r, c)) || !std::isfinite(view.pose(r, c)))
                    throw Error(where(), "a pose row needs 4 finite numbers: '" + line + "'");
            if (row >> word) throw Error(where(), "a pose row has more than 4 numbers: '" + line + "'");
        }
        poses.push_back(view);
    }
    return poses;
}

}  // namespace picoscan
