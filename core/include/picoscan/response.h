// The projector's response (gamma), measured from flat grey frames, and its correction.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace picoscan {

// Grey levels to project as flat frames for measuring the response: `count` levels from 0 to
// 255, evenly spaced.
std::vector<int> response_levels(int count = 17);
// The file name of the flat frame of one level (level_LLL.png), as patterns and response use it.
std::string flat_level_file(int level);

struct ProjectorResponse {
    std::vector<int> levels;
    std::vector<double> relative_light;  // camera response per level, 0 at level 0, 1 at 255
    double gamma = 1;                    // best power-law fit, for reporting
    cv::Mat inverse_lut;                 // 256 x CV_8U: level to send for each wanted light level
};

// Measures the response from camera images of flat frames of the given levels (same order),
// averaging the pixels that the projector lights well (or those in `mask`). Throws Error when
// the levels are not increasing from 0 to 255, the images differ in size, or the camera sees
// no usable change of light.
ProjectorResponse measure_projector_response(const std::vector<int>& levels, const std::vector<cv::Mat>& images,
                                             const cv::Mat& mask = cv::Mat());

}  // namespace picoscan
