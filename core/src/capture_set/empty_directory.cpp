#include "picoscan/capture_set.h"
#include "picoscan/error.h"

#include <filesystem>

namespace fs = std::filesystem;

namespace picoscan {

void require_empty_directory(const std::string& directory) {
    if (fs::exists(directory) && (!fs::is_directory(directory) || !fs::is_empty(directory)))
        throw Error(directory, "output folder exists and is not empty (nothing is overwritten)");
}

}  // namespace picoscan
