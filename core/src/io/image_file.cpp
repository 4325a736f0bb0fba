#include "picoscan/capture_set.h"
#include "picoscan/error.h"
#include "picoscan/file_output.h"

#include "common/third_party_output.h"
#include "io/image_codecs.h"

#include <filesystem>
#include <vector>

namespace picoscan {

cv::Mat read_image_file(const std::string& path, int flags) {
    cv::Mat image;
    std::string problem;
    detail::ThirdPartyOutput decoder;
    try {
        image = detail::imread(path, flags);
    } catch (const cv::Exception& error) {
        image.release();
        problem = error.msg;
    }
    if (image.empty()) {
        const std::string printed = decoder.text();
        throw Error(path, "unreadable or corrupt image" +
                              detail::attached(printed.empty() ? problem : printed, "the decoder"));
    }
    decoder.discard();  // warnings about an image that decoded (a colour profile, say)
    return image;
}

void write_image_file(const cv::Mat& image, const std::string& path) {
    std::vector<uint8_t> bytes;
    bool encoded = false;
    try {
        encoded = !image.empty() && detail::imencode(std::filesystem::path(path).extension().string(), image, bytes);
    } catch (const cv::Exception& error) {
        throw Error(path, "cannot encode the image: " + error.msg);
    }
    if (!encoded) throw Error(path, "cannot encode the image");
    write_file_atomically(path, std::string(bytes.begin(), bytes.end()));
}

}  // namespace picoscan
