#include "cli_support.h"

#include "picoscan/error.h"

#include <unistd.h>

#include <algorithm>
#include <climits>
#include <cstdio>

namespace fs = std::filesystem;

namespace picoscan::cli {

ProgressCallback terminal_progress() {
    if (!isatty(STDERR_FILENO)) return nullptr;
    return [](double fraction, const std::string& stage) {
        const int width = 30, filled = static_cast<int>(fraction * width + 0.5);
        std::fprintf(stderr, "\r%-12s [%s%s] %3d%%", stage.c_str(), std::string(filled, '#').c_str(),
                     std::string(width - filled, ' ').c_str(), static_cast<int>(fraction * 100 + 0.5));
        if (fraction >= 1.0) std::fprintf(stderr, "\n");
        std::fflush(stderr);
        return true;
    };
}

std::string single_input(const Arguments& arguments) {
    const std::vector<std::string>& inputs = arguments.inputs();
    if (inputs.empty()) throw Error("input", "give one input file first (see --help)");
    if (inputs.size() > 1) throw Error(inputs[1], "unexpected second input file");
    if (!fs::is_regular_file(inputs[0])) throw Error(inputs[0], "no such file");
    return inputs[0];
}

double seconds_since(std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

fs::path absolute_path(const std::string& path) { return fs::weakly_canonical(fs::absolute(path)); }

bool is_inside(const fs::path& path, const fs::path& directory) {
    const fs::path relative = path.lexically_relative(directory);
    return !relative.empty() && *relative.begin() != "..";
}

std::string lowercase_extension(const std::string& path) {
    std::string extension = fs::path(path).extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(), ::tolower);
    return extension;
}

void check_extension(const std::string& path, const std::set<std::string>& allowed, const std::string& what) {
    if (path.empty() || allowed.count(lowercase_extension(path))) return;
    std::string list;
    for (const auto& extension : allowed) list += (list.empty() ? "" : " or ") + extension;
    throw Error(path, what + " must end in " + list);
}

void check_output_name(const std::string& path, const std::string& subject) {
    // ".tmp-PID-N" (atomic_write.cpp) needs at most 5 + 10 + 1 + 20 characters.
    constexpr size_t kTemporarySuffix = 36;
    constexpr size_t kLongestName = NAME_MAX - kTemporarySuffix;
    // A folder's own files (a capture set's frame names) need room inside it too.
    constexpr size_t kLongestPath = PATH_MAX - kTemporarySuffix - 64;
    if (path.size() > kLongestPath)
        throw Error(subject, "the path is " + std::to_string(path.size()) + " characters long; at most " +
                                 std::to_string(kLongestPath) + " are allowed");
    for (const fs::path& part : fs::path(path))
        if (part.native().size() > kLongestName)
            throw Error(subject, "the name '" + part.native().substr(0, 24) + "...' is " +
                                     std::to_string(part.native().size()) + " characters long; at most " +
                                     std::to_string(kLongestName) + " are allowed (the file system's limit, " +
                                     std::to_string(NAME_MAX) + ", less room for the temporary file)");
}

void refuse_overwriting(const std::string& output, const std::vector<std::string>& input_files,
                        const std::vector<std::string>& input_folders) {
    if (output.empty()) return;
    check_output_name(output, output.size() > 80 ? output.substr(0, 77) + "..." : output);
    const fs::path target = absolute_path(output);
    for (const std::string& input : input_files)
        if (!input.empty() && target == absolute_path(input)) throw Error(output, "output would overwrite an input file");
    for (const std::string& folder : input_folders) {
        if (folder.empty()) continue;
        const fs::path directory = absolute_path(folder);
        if (target == directory || is_inside(target, directory))
            throw Error(output, "output must not be written into the capture directory " + folder);
    }
}

}  // namespace picoscan::cli
