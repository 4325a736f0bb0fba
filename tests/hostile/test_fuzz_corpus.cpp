// Every committed fuzz seed (tests/fuzz/corpus/<reader>/), the regressions included, through
// its reader in the normal build: each file is read or refused with picoscan::Error, within
// the fuzzers' 1 s slow-input limit. The libFuzzer targets explore beyond these seeds.
#include "picoscan/calibration.h"
#include "picoscan/error.h"
#include "picoscan/io.h"
#include "picoscan/patterns.h"
#include "picoscan/simulate.h"
#include "support/test_support.h"

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <functional>
#include <map>

namespace fs = std::filesystem;
using namespace picoscan;

TEST(FuzzCorpus, EverySeedIsReadOrRefusedWithinOneSecond) {
    const std::map<std::string, std::function<void(const std::string&)>> readers{
        {"manifest", [](const std::string& path) { read_manifest(path); }},
        {"calibration", [](const std::string& path) { read_calibration(path); }},
        {"scene", [](const std::string& path) { read_scene(path); }},
        {"poses", [](const std::string& path) { read_poses(path); }},
        {"ply", [](const std::string& path) { read_ply(path); }},
        {"stl", [](const std::string& path) { read_stl(path); }},
    };
    const fs::path corpus = fs::path(PICOSCAN_SOURCE_DIR) / "tests" / "fuzz" / "corpus";
    int seeds = 0, refused = 0;
    for (const auto& [reader, read] : readers) {
        ASSERT_TRUE(fs::is_directory(corpus / reader)) << "no seeds for " << reader;
        for (const auto& entry : fs::directory_iterator(corpus / reader)) {
            const std::string path = entry.path().string();
            const auto start = std::chrono::steady_clock::now();
            try {
                read(path);
            } catch (const Error& error) {
                ++refused;
                EXPECT_NE(std::string(error.what()).find(path), std::string::npos) << "the error names another file";
            }
            const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
            EXPECT_LT(seconds, 1.0) << path;
            ++seeds;
        }
    }
    std::printf("[fuzz corpus] %d seeds read, %d refused with an Error naming the file\n", seeds, refused);
    EXPECT_GE(seeds, 25);
    // The regressions are refused, not read: deep nesting, 32-bit wraps, an unclosed list, a
    // YAML root that is not a mapping (OpenCV's parser loops forever on some).
    for (const char* regression : {"scene/regress_deep_json", "scene/regress_deep_yaml", "scene/regress_deep_yaml_dashes",
                                   "scene/regress_int32_wrap", "scene/regress_yaml_root_sequence",
                                   "scene/regress_yaml_root_sequence_found", "manifest/regress_yaml_root_sequence",
                                   "manifest/regress_deep_json",
                                   "manifest/regress_int32_wrap", "calibration/regress_unclosed_list.yml"}) {
        const std::string path = (corpus / regression).string();
        const std::string reader = fs::path(regression).parent_path().string();
        EXPECT_THROW(readers.at(reader)(path), Error) << path;
    }
}
