// Loads libopencv_imgcodecs with dlopen when an image is first read or written (image_codecs.h
// says why). The two functions are looked up by their C++ symbol names, the ABI of OpenCV 4
// built with GCC's C++11 strings: a library without them is refused by name, never guessed at.
#include "io/image_codecs.h"

#include "picoscan/error.h"

#include <opencv2/imgcodecs.hpp>  // declarations only: the types below are checked against them

#include <dlfcn.h>

#include <type_traits>

namespace picoscan::detail {

namespace {

using Imread = cv::Mat (*)(const std::string&, int);
using Imencode = bool (*)(const std::string&, const cv::_InputArray&, std::vector<uchar>&, const std::vector<int>&);
static_assert(std::is_same_v<decltype(&cv::imread), Imread>, "cv::imread changed: update its symbol name");
static_assert(std::is_same_v<decltype(&cv::imencode), Imencode>, "cv::imencode changed: update its symbol name");

struct Codecs {
    Imread imread = nullptr;
    Imencode imencode = nullptr;
    std::string problem;  // why they could not be loaded; empty when they were
};

// Found once, on first use (thread-safe: a function's static).
const Codecs& codecs() {
    static const Codecs loaded = [] {
        Codecs codecs;
        // The library stays loaded for the life of the process: its functions are in use.
        void* library = dlopen(PICOSCAN_OPENCV_IMGCODECS_SONAME, RTLD_NOW | RTLD_LOCAL);
        if (!library) {
            const char* error = dlerror();
            codecs.problem = error ? error : PICOSCAN_OPENCV_IMGCODECS_SONAME;
            return codecs;
        }
        const char* imread_name = "_ZN2cv6imreadERKNSt7__cxx1112basic_stringIcSt11char_traitsIcESaIcEEEi";
        const char* imencode_name =
            "_ZN2cv8imencodeERKNSt7__cxx1112basic_stringIcSt11char_traitsIcESaIcEEERKNS_11_InputArrayERSt6vectorIhSaIhEERKSB_IiSaIiEE";
        codecs.imread = reinterpret_cast<Imread>(dlsym(library, imread_name));
        codecs.imencode = reinterpret_cast<Imencode>(dlsym(library, imencode_name));
        if (!codecs.imread || !codecs.imencode)
            codecs.problem = std::string(PICOSCAN_OPENCV_IMGCODECS_SONAME) + " lacks cv::imread or cv::imencode";
        return codecs;
    }();
    if (!loaded.problem.empty()) throw Error("image codecs", "cannot load OpenCV's image codecs: " + loaded.problem);
    return loaded;
}

}  // namespace

cv::Mat imread(const std::string& path, int flags) { return codecs().imread(path, flags); }

bool imencode(const std::string& extension, const cv::Mat& image, std::vector<uint8_t>& bytes) {
    return codecs().imencode(extension, image, bytes, std::vector<int>());
}

}  // namespace picoscan::detail
