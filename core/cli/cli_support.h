// What every picoscan command shares besides its arguments: the progress bar, timing, and
// the checks of output file names made before any work.
#pragma once

#include "arguments.h"

#include "picoscan/cloud.h"
#include "picoscan/io.h"
#include "picoscan/progress.h"

#include <chrono>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

namespace picoscan::cli {

// A one-line progress bar on a terminal; nullptr (silent) when stderr is not one.
ProgressCallback terminal_progress();
// The one input file a command takes (clean, mesh, section); Error naming it when it is missing.
std::string single_input(const Arguments& arguments);
double seconds_since(std::chrono::steady_clock::time_point start);

std::filesystem::path absolute_path(const std::string& path);
bool is_inside(const std::filesystem::path& path, const std::filesystem::path& directory);
std::string lowercase_extension(const std::string& path);
// Throws Error naming `path` when it is given and does not end in one of `allowed`.
void check_extension(const std::string& path, const std::set<std::string>& allowed, const std::string& what);
// Throws Error naming `subject` when `path` cannot be a file PicoScan writes: a name (any
// part of the path) longer than NAME_MAX less the room its temporary file's suffix needs, or
// a whole path longer than PATH_MAX less that room and the names written inside a folder.
void check_output_name(const std::string& path, const std::string& subject);
// Throws Error naming `output` when it is one of the input files or inside one of the capture
// folders, or when its name is too long (check_output_name).
void refuse_overwriting(const std::string& output, const std::vector<std::string>& input_files,
                        const std::vector<std::string>& input_folders = {});

}  // namespace picoscan::cli
