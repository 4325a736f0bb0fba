#include "support/test_support.h"

#include "picoscan/error.h"

#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <vector>

namespace fs = std::filesystem;

namespace picoscan::test_support {

namespace {
struct TempDirs {
    std::vector<fs::path> paths;
    ~TempDirs() {
        std::error_code ignored;
        for (const auto& path : paths) fs::remove_all(path, ignored);
    }
};
TempDirs& temp_dirs() {
    static TempDirs dirs;
    return dirs;
}
}  // namespace

std::string datasets_dir() {
    const char* override_dir = std::getenv("PICOSCAN_DATASETS");
    fs::path dir = override_dir ? fs::path(override_dir) : fs::path(PICOSCAN_DATASETS_DIR);
    std::error_code error;
    if (!fs::is_directory(dir, error)) return "";
    return fs::canonical(dir).string();
}

std::string make_temp_dir(const std::string& name) {
    fs::path base = fs::temp_directory_path();
    for (int attempt = 0;; ++attempt) {
        fs::path dir = base / ("picoscan-test-" + name + "-" + std::to_string(::getpid()) + "-" +
                               std::to_string(attempt));
        if (fs::create_directories(dir)) {
            temp_dirs().paths.push_back(dir);
            return dir.string();
        }
    }
}

int run_command(const std::string& command, std::string* output) {
    std::string full = command + " 2>&1";
    FILE* pipe = popen(full.c_str(), "r");
    if (!pipe) return -1;
    std::array<char, 4096> buffer{};
    std::string text;
    while (fgets(buffer.data(), buffer.size(), pipe)) text += buffer.data();
    int status = pclose(pipe);
    if (output) *output = text;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string cli_path() { return PICOSCAN_CLI; }

std::string error_of(const std::function<void()>& action) {
    try {
        action();
    } catch (const Error& error) {
        return error.what();
    }
    return "";
}

CliResult run_picoscan(const std::string& arguments) {
    CliResult result;
    result.exit_code = run_command(cli_path() + " " + arguments, &result.output);
    return result;
}

}  // namespace picoscan::test_support
