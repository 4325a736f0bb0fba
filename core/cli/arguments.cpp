#include "arguments.h"

#include "cli_support.h"

#include "picoscan/error.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

namespace picoscan::cli {

namespace {

bool looks_like_option(const std::string& word) { return word.rfind("--", 0) == 0 || word == "-h"; }

// Options whose empty value means something (no file-name prefix or suffix); for every other
// option an empty value is a mistake, such as an unset shell variable.
const std::set<std::string> kMayBeEmpty{"--prefix", "--suffix"};
// Options that name files or folders PicoScan writes: checked here, before any work.
const std::set<std::string> kOutputOptions{"--out", "--mesh", "--preview", "--report", "--svg", "--dxf"};

}  // namespace

Arguments::Arguments(int argc, char** argv, int first, const ArgumentRules& rules) : list_options_(rules.list_options) {
    int index = first;
    if (rules.takes_inputs)
        for (; index < argc && !looks_like_option(argv[index]); ++index) inputs_.push_back(argv[index]);
    for (; index < argc; ++index) {
        std::string key = argv[index];
        if (key == "-h") key = "--help";
        if (!looks_like_option(key)) throw Error(key, "unexpected argument (options start with --)");
        const bool is_list = list_options_.count(key) > 0;
        if (values_.count(key) && !is_list) throw Error(key, "is given more than once");
        std::vector<std::string>& values = values_[key];
        if (key == "--help" || rules.flags.count(key)) continue;
        occurrence_starts_[key].push_back(values.size());
        if (index + 1 >= argc || looks_like_option(argv[index + 1])) throw Error(key, "needs a value");
        values.push_back(argv[++index]);
        if (values.back().empty() && !kMayBeEmpty.count(key)) throw Error(key, "must not be empty");
        if (kOutputOptions.count(key)) check_output_name(values.back(), key);
        // Further values up to the next option belong to the same key (--captures A B C).
        while (index + 1 < argc && !looks_like_option(argv[index + 1])) {
            if (!is_list) throw Error(argv[index + 1], "unexpected argument after " + key + " (it takes one value)");
            values.push_back(argv[++index]);
            if (values.back().empty()) throw Error(key, "must not be empty");
        }
    }
    for (const std::string& input : inputs_)
        if (input.empty()) throw Error("input file", "an empty name was given");
    require_output_folders();
}

// A file output's folder must exist (or be --out, which the command creates): otherwise the
// write would fail only after all the work.
void Arguments::require_output_folders() const {
    static const std::set<std::string> file_extensions{".ply", ".stl", ".obj", ".3mf", ".png", ".svg", ".dxf", ".yml", ".yaml",
                                                       ".xml", ".json", ".html", ".htm", ".txt"};
    const auto out = values_.find("--out");
    const std::string made_folder = out != values_.end() && !out->second.empty() ? out->second.back() : "";
    for (const std::string& key : kOutputOptions) {
        const auto found = values_.find(key);
        if (found == values_.end() || found->second.empty()) continue;
        const std::filesystem::path path = found->second.back(), folder = path.parent_path();
        if (key == "--out" && !file_extensions.count(lowercase_extension(path.string()))) continue;  // a folder
        if (folder.empty()) continue;
        if (key != "--out" && !made_folder.empty()) {
            const std::filesystem::path inside = absolute_path(folder.string()), made = absolute_path(made_folder);
            if (inside == made || is_inside(inside, made)) continue;
        }
        if (std::error_code error; !std::filesystem::is_directory(folder, error))
            throw Error(key, "the folder '" + folder.string() + "' does not exist");
    }
}

bool Arguments::flag(const std::string& key) const {
    used_.insert(key);
    return has(key);
}

std::string Arguments::text(const std::string& key, const std::string& fallback) const {
    used_.insert(key);
    const auto found = values_.find(key);
    return found == values_.end() || found->second.empty() ? fallback : found->second.back();
}

std::string Arguments::required(const std::string& key) const {
    if (!has(key)) throw Error(key, "is required (see --help)");
    const std::string value = text(key);
    if (value.empty()) throw Error(key, "must not be empty");
    return value;
}

std::vector<std::string> Arguments::list(const std::string& key) const {
    used_.insert(key);
    const auto found = values_.find(key);
    return found == values_.end() ? std::vector<std::string>{} : found->second;
}

std::vector<std::vector<std::string>> Arguments::occurrences(const std::string& key) const {
    used_.insert(key);
    std::vector<std::vector<std::string>> groups;
    const auto found = values_.find(key);
    if (found == values_.end()) return groups;
    const std::vector<size_t>& starts = occurrence_starts_.at(key);
    for (size_t k = 0; k < starts.size(); ++k) {
        const size_t end = k + 1 < starts.size() ? starts[k + 1] : found->second.size();
        groups.emplace_back(found->second.begin() + static_cast<long>(starts[k]), found->second.begin() + static_cast<long>(end));
    }
    return groups;
}

double Arguments::number(const std::string& key, double fallback) const {
    if (!has(key)) return used_.insert(key), fallback;
    const std::string value = text(key);
    try {
        size_t end = 0;
        const double parsed = std::stod(value, &end);
        if (end != value.size() || !std::isfinite(parsed)) throw std::invalid_argument(value);
        return parsed;
    } catch (const std::exception&) {
        throw Error(key, "expects a number, got '" + value + "'");
    }
}

int Arguments::integer(const std::string& key, int fallback) const {
    const double value = number(key, fallback);
    if (!(std::abs(value) < 1e9) || value != std::floor(value)) throw Error(key, "expects a whole number");
    return static_cast<int>(value);
}

cv::Size Arguments::size(const std::string& key) const {
    const std::string value = required(key);
    int width = 0, height = 0;
    char separator = 0, extra = 0;
    if (std::sscanf(value.c_str(), "%d%c%d%c", &width, &separator, &height, &extra) != 3 || separator != 'x')
        throw Error(key, "expects WIDTHxHEIGHT, e.g. 854x480, got '" + value + "'");
    return {width, height};
}

std::vector<double> Arguments::numbers(const std::string& key, size_t count) const {
    const std::string text_value = text(key);
    const std::string expected = "expects " + std::to_string(count) + " comma-separated numbers, got '" + text_value + "'";
    std::vector<double> values;
    std::stringstream stream(text_value);
    std::string item;
    while (std::getline(stream, item, ',')) {
        try {
            size_t end = 0;
            values.push_back(std::stod(item, &end));
            if (end != item.size() || !std::isfinite(values.back())) throw std::invalid_argument(item);
        } catch (const std::exception&) {
            throw Error(key, expected);
        }
    }
    if (values.size() != count) throw Error(key, expected);
    return values;
}

void Arguments::reject_unknown() const {
    for (const auto& entry : values_)
        if (!used_.count(entry.first)) throw Error(entry.first, "unknown option (see --help)");
}

}  // namespace picoscan::cli
