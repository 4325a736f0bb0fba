// Poses files: the view -> model pose of each view, as stitch writes them and reads them back.
#include "io/io_detail.h"
#include "picoscan/error.h"
#include "picoscan/file_output.h"
#include "picoscan/io.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace picoscan {

namespace {

constexpr size_t kMaxPosesFileBytes = 16u << 20;  // thousands of views are a few hundred KB
constexpr const char* kNotAligned = " NOT-ALIGNED";
constexpr const char* kPlacement = "# placement ";  // views after it belong to that placement (1, 2, ...)
constexpr size_t kMostPoses = 10000;              // views of one model
constexpr double kFarthestTranslationMm = 1e6;

}  // namespace

void write_poses(const std::vector<ViewPose>& poses, const std::string& path) {
    std::string text = "# PicoScan view -> model poses (4x4, row by row); model frame = first view's camera\n";
    const bool placements = std::any_of(poses.begin(), poses.end(), [](const ViewPose& view) { return view.placement != 0; });
    int placement = -1;
    for (const ViewPose& view : poses) {
        if (view.placement < 0) throw Error(path, "view '" + view.name + "' has a negative placement");
        if (placements && view.placement != placement) {
            placement = view.placement;
            text += "# placement " + std::to_string(placement + 1) + "\n";
        }
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
    for (size_t offset = 0; offset < text.size(); ++offset) {
        const unsigned char byte = static_cast<unsigned char>(text[offset]);
        if ((byte < 0x20 && byte != '\n' && byte != '\r' && byte != '\t') || byte > 0x7e)
            throw Error(path, "is not a plain ASCII text file (byte " + std::to_string(int(byte)) + " at offset " +
                                  std::to_string(offset) + ")");
    }
    std::stringstream lines(text);
    std::vector<ViewPose> poses;
    std::string line;
    int line_number = 0;
    int placement = 0;
    auto where = [&] { return path + ":" + std::to_string(line_number); };
    while (std::getline(lines, line)) {
        ++line_number;
        if (line.rfind(kPlacement, 0) == 0) {
            const std::string number = line.substr(std::char_traits<char>::length(kPlacement));
            double value = 0;
            if (!detail::parse_double(number, value) || value < 1 || value > kMostPoses || value != std::floor(value))
                throw Error(where(), "a placement line needs a whole number from 1: '" + line + "'");
            placement = static_cast<int>(value) - 1;
            continue;
        }
        if (line.empty() || line[0] == '#') continue;
        ViewPose view;
        view.placement = placement;
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
        const cv::Matx44d& pose = view.pose;
        if (pose(3, 0) != 0 || pose(3, 1) != 0 || pose(3, 2) != 0 || pose(3, 3) != 1)
            throw Error(where(), "a pose's last row must be 0 0 0 1");
        const cv::Matx33d rotation = pose.get_minor<3, 3>(0, 0);
        if (!(cv::norm(rotation.t() * rotation - cv::Matx33d::eye()) < 1e-4) || !(cv::determinant(rotation) > 0))
            throw Error(where(), "a pose's upper left 3x3 must be a rotation");
        for (int r = 0; r < 3; ++r)
            if (!(std::abs(pose(r, 3)) <= kFarthestTranslationMm))
                throw Error(where(), "a pose's translation is beyond 1 km");
        if (poses.size() >= kMostPoses) throw Error(where(), "more than " + std::to_string(kMostPoses) + " poses");
        poses.push_back(view);
    }
    return poses;
}

}  // namespace picoscan
