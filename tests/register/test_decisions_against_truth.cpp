// Every registration decision of the suite's turntable scans, judged against the truth: a tool
// (disabled in CTest: 20-40 min on the loaded 2-core machine) to compare two builds decision
// by decision when a change to registration must not turn a right result wrong or refused.
//   build/tests/test_register --gtest_also_run_disabled_tests --gtest_filter='RegistrationDecisions.*' > A.log
//   (the same with the other build > B.log)
//   /usr/bin/python3 benchmarks/bench_register_decisions_compare.py A.log B.log
// Prints one "D" line per decision: register_pair with no guess on each neighbouring pair of
// the round (and the speckled part's top view), then align_views in feature, known-axis and
// turntable-round modes; right is within 1 degree and 1 mm of the true pose.
// DECISIONS_ONLY=pairs or DECISIONS_ONLY=align runs half of them.
#include "picoscan/register.h"
#include "support/turntable_scan.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <string>

using namespace picoscan;
namespace ts = picoscan::test_support;

namespace {

std::string verdict(bool aligned, const std::string& problem, const cv::Matx44d& truth, const cv::Matx44d& pose,
                    const cv::Vec3d& at) {
    if (!aligned) return "REFUSED " + problem;
    const PoseDifference d = pose_difference(truth, pose, at);
    char text[200];
    std::snprintf(text, sizeof text, "%s rot %.4f deg shift %.4f mm",
                  d.rotation_deg < 1 && d.translation_mm < 1 ? "RIGHT" : "WRONG", d.rotation_deg, d.translation_mm);
    return text;
}

void decide(const std::string& label, const ts::TurntableScan& scan, size_t round, bool top_view) {
    const char* only = std::getenv("DECISIONS_ONLY");
    const bool pairs = !only || std::string(only) == "pairs", aligns = !only || std::string(only) == "align";
    std::vector<std::pair<size_t, size_t>> list;
    for (size_t k = 0; k < round; ++k) list.push_back({k, (k + 1) % round});
    if (top_view) list.push_back({0, round});
    if (pairs)
        for (const auto& [fixed, moving] : list) {
            const std::clock_t start = std::clock();
            const PairRegistration pair = register_pair(scan.views[fixed], scan.views[moving]);
            const double cpu = double(std::clock() - start) / CLOCKS_PER_SEC;
            const cv::Matx44d truth = scan.part_to_camera[fixed] * scan.part_to_camera[moving].inv();
            std::printf("D %s pair %zu<-%zu: %s | cpu %.2f\n", label.c_str(), fixed, moving,
                        verdict(pair.problem.empty(), pair.problem, truth, pair.transform, scan.centroid(moving)).c_str(), cpu);
            std::fflush(stdout);
        }
    if (!aligns) return;
    const cv::Matx44d part = scan.part_to_camera[0];
    const TurntableAxis axis{{part(0, 3), part(1, 3), part(2, 3)}, {part(0, 2), part(1, 2), part(2, 2)}, 45};
    for (const char* mode : {"features", "axis", "round"}) {
        RegistrationOptions options;
        options.turntable_round = std::string(mode) == "round";
        const size_t count = std::string(mode) == "features" ? scan.views.size() : round;
        const std::vector<ScanView> views(scan.views.begin(), scan.views.begin() + static_cast<long>(count));
        const std::vector<std::string> names(scan.names.begin(), scan.names.begin() + static_cast<long>(count));
        const Alignment alignment = align_views(views, names, options,
                                                std::string(mode) == "axis" ? std::optional<TurntableAxis>(axis) : std::nullopt);
        for (size_t i = 0; i < alignment.views.size(); ++i) {
            const ViewAlignment& view = alignment.views[i];
            std::printf("D %s %s view %zu: %s\n", label.c_str(), mode, i,
                        verdict(view.aligned, view.problem, scan.true_view_to_model[i], view.pose, scan.centroid(i)).c_str());
        }
        std::fflush(stdout);
    }
}

}  // namespace

TEST(RegistrationDecisions, DISABLED_AgainstTheTruth) {
    decide("speckled", ts::turntable_scan(), 8, true);
    for (ts::PlainPart part : ts::kPlainParts) decide(ts::plain_part_name(part), ts::plain_turntable_scan(part), 8, false);
}
