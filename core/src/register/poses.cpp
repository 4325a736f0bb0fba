// Poses files: written by stitch, read back as --initial-poses. The reader takes one line
// at a time (linear time, no nesting) and checks every number before use.
#include "picoscan/error.h"
#include "picoscan/io.h"
#include "picoscan/register.h"

#include "common/storage_file.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>

namespace picoscan {

namespace {

constexpr size_t kMostPoses = 10000;         // views of one model
constexpr double kFarthestTranslationMm = 1e6;

}  // namespace

std::string format_poses(const std::vector<ViewAlignment>& views) {
    std::string text = "# PicoScan view -> model poses (4x4, row by row); model frame = first view's camera\n";
    char line[512];
    for (const ViewAlignment& view : views) {
        text += view.name + (view.aligned ? "" : " NOT-ALIGNED") + "\n";
        for (int r = 0; r < 4; ++r) {
            std::snprintf(line, sizeof line, "%.9f %.9f %.9f %.9f\n", view.pose(r, 0), view.pose(r, 1),
                          view.pose(r, 2), view.pose(r, 3));
            text += line;
        }
    }
    return text;
}

std::vector<cv::Matx44d> read_poses(const std::string& path) {
    std::istringstream text(detail::read_text_file(path, "poses file"));
    std::vector<cv::Matx44d> poses;
    std::string line;
    int line_number = 0;
    auto fail = [&](const std::string& problem) -> void {
        throw Error(path, "line " + std::to_string(line_number) + ": " + problem);
    };
    while (std::getline(text, line)) {
        ++line_number;
        if (line.find_first_not_of(" \t\r") == std::string::npos || line[0] == '#') continue;
        if (poses.size() >= kMostPoses) fail("more than " + std::to_string(kMostPoses) + " poses");
        cv::Matx44d pose;
        for (int r = 0; r < 4; ++r) {
            ++line_number;
            if (!std::getline(text, line)) fail("the file ends inside a pose (a name line, then 4 rows of 4 numbers)");
            const char* at = line.c_str();
            for (int c = 0; c < 4; ++c) {
                char* end = nullptr;
                errno = 0;
                pose(r, c) = std::strtod(at, &end);
                if (end == at || errno == ERANGE || !std::isfinite(pose(r, c)))
                    fail("a pose row needs 4 finite numbers: '" + line.substr(0, 80) + "'");
                at = end;
            }
            while (*at == ' ' || *at == '\t' || *at == '\r') ++at;
            if (*at != '\0') fail("a pose row holds more than 4 numbers: '" + line.substr(0, 80) + "'");
        }
        const cv::Matx33d rotation(pose(0, 0), pose(0, 1), pose(0, 2), pose(1, 0), pose(1, 1), pose(1, 2), pose(2, 0),
                                   pose(2, 1), pose(2, 2));
        if (pose(3, 0) != 0 || pose(3, 1) != 0 || pose(3, 2) != 0 || pose(3, 3) != 1)
            fail("a pose's last row must be 0 0 0 1");
        if (!(cv::norm(rotation.t() * rotation - cv::Matx33d::eye()) < 1e-4) || !(cv::determinant(rotation) > 0))
            fail("a pose's upper left 3x3 must be a rotation");
        for (int r = 0; r < 3; ++r)
            if (!(std::abs(pose(r, 3)) <= kFarthestTranslationMm)) fail("a pose's translation is beyond 1 km");
        poses.push_back(pose);
    }
    if (poses.empty()) throw Error(path, "holds no poses");
    return poses;
}

}  // namespace picoscan
