// The PicoScan MeshLab plugin, driven through the real meshlabserver under xvfb-run with
// .mlx scripts; the saved meshes are read back with the core and checked against ground
// truth and against the CLI.
#include "picoscan/calibration.h"
#include "picoscan/error.h"
#include "picoscan/fit.h"
#include "picoscan/io.h"
#include "picoscan/mesh.h"
#include "picoscan/pipeline.h"
#include "picoscan/register.h"
#include "picoscan/simulate.h"
#include "support/test_support.h"
#include "support/turntable_scan.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <map>
#include <set>
#include <sstream>
#include <tuple>
#include <vector>

using namespace picoscan;
using test_support::make_temp_dir;
using test_support::run_command;

namespace {

struct Param {
    std::string type, name, value;
};
using Params = std::vector<Param>;

// meshlabserver (2020.09) needs every parameter of a filter in the script, so each filter's
// full list with its defaults is here; tests override single values.
const Params kSimulateDefaults{
    {"RichString", "sceneFile", ""},     {"RichInt", "partView", "-1"},         {"RichString", "calibrationFile", ""},
    {"RichInt", "shifts", "24"},
    {"RichInt", "periodBits", "4"},      {"RichFloat", "fullScale", "220"},     {"RichFloat", "noise", "1"},           {"RichFloat", "blur", "0.7"},
    {"RichInt", "seed", "1"},            {"RichString", "saveCaptureFolder", ""}, {"RichBool", "binaryOnly", "false"},
    {"RichFloat", "minContrast", "15"},  {"RichFloat", "minModulation", "4"},   {"RichEnum", "output", "0"},
    {"RichInt", "meshStep", "1"}};
const Params kReconstructDefaults{
    {"RichString", "captureFolder", ""}, {"RichString", "calibrationFile", ""}, {"RichString", "secondCaptureFolder", ""},
    {"RichEnum", "sequence", "0"},
    {"RichString", "manifestFile", ""},  {"RichInt", "shifts", "12"},            {"RichInt", "periods", "32"},
    {"RichInt", "grayBits", "0"},        {"RichBool", "binaryOnly", "false"},    {"RichFloat", "minContrast", "15"},
    {"RichFloat", "minModulation", "4"}, {"RichEnum", "output", "0"},            {"RichInt", "meshStep", "1"}};
const Params kCleanDefaults{{"RichFloat", "minQuality", "0"},      {"RichFloat", "maxGrazingDeg", "80"},
                            {"RichInt", "windowPx", "2"},          {"RichFloat", "outlierSigma", "4"},
                            {"RichFloat", "radiusFootprints", "4"}, {"RichInt", "minNeighbours", "3"},
                            {"RichInt", "minClusterPoints", "100"}};
const Params kAlignDefaults{{"RichInt", "orbFeatures", "6000"},
                            {"RichFloat", "icpMaxDistance", "3"},
                            {"RichFloat", "sampleSpacing", "0.7"},
                            {"RichFloat", "minOverlap", "0.08"},
                            {"RichString", "placements", ""},
                            {"RichEnum", "mode", "0"},
                            {"RichPoint3f", "turntableAxisPoint", "0 0 0"},
                            {"RichPoint3f", "turntableAxisDirection", "0 0 0"},
                            {"RichFloat", "turntableStepDeg", "0"}};
const Params kFuseDefaults{{"RichEnum", "method", "0"},             {"RichEnum", "fill", "0"},
                           {"RichFloat", "sampleSpacing", "0.4"},
                           {"RichFloat", "poissonTriangleSize", "1"}, {"RichFloat", "poissonDistance", "0.1"},
                           {"RichFloat", "frontMaxRadius", "4"},     {"RichFloat", "maxHoleDiameter", "10"},
                           {"RichInt", "targetFaces", "0"}};
const Params kSaveViewsDefaults{{"RichString", "viewFolder", ""}};
// In the order the filter declares them (meshlabserver matches a RichMesh by position).
const Params kSectionDefaults{{"RichEnum", "axis", "2"},       {"RichFloat", "at", "0"},   {"RichMesh", "scanLayer", "0"},
                              {"RichFloat", "tolerance", "0"}, {"RichFloat", "band", "3"}, {"RichString", "dxfFile", ""}};
const Params kMeasureDefaults{
    {"RichEnum", "shape", "0"}, {"RichBool", "selectedOnly", "false"}, {"RichBool", "modelFrame", "true"}};

std::string filter(const std::string& name, Params params, const std::map<std::string, std::string>& overrides = {}) {
    for (const auto& [key, value] : overrides) {
        bool found = false;
        for (Param& param : params)
            if (param.name == key) param.value = value, found = true;
        EXPECT_TRUE(found) << "no parameter " << key << " in " << name;
    }
    std::string xml = " <filter name=\"" + name + "\">\n";
    for (const Param& param : params) {
        if (param.type == "RichPoint3f") {  // value "x y z"
            std::istringstream xyz(param.value);
            std::string x, y, z;
            xyz >> x >> y >> z;
            xml += "  <Param type=\"RichPoint3f\" name=\"" + param.name + "\" x=\"" + x + "\" y=\"" + y + "\" z=\"" + z + "\"/>\n";
            continue;
        }
        xml += "  <Param type=\"" + param.type + "\" name=\"" + param.name + "\" value=\"" + param.value + "\"";
        if (param.type == "RichEnum") xml += " enum_cardinality=\"4\"";  // required by MeshLab's parser
        xml += "/>\n";
    }
    return xml + " </filter>\n";
}

std::string simulate(const std::map<std::string, std::string>& overrides) {
    return filter("PicoScan: Simulate Scan", kSimulateDefaults, overrides);
}
std::string reconstruct(const std::map<std::string, std::string>& overrides) {
    return filter("PicoScan: Reconstruct from Capture Set", kReconstructDefaults, overrides);
}
std::string clean(const std::map<std::string, std::string>& overrides = {}) {
    return filter("PicoScan: Clean Scan", kCleanDefaults, overrides);
}
std::string align(const std::map<std::string, std::string>& overrides = {}) {
    return filter("PicoScan: Align Layers", kAlignDefaults, overrides);
}
std::string fuse(const std::map<std::string, std::string>& overrides = {}) {
    return filter("PicoScan: Fuse and Mesh", kFuseDefaults, overrides);
}
std::string save_views(const std::string& folder) {
    return filter("PicoScan: Save Views for Project", kSaveViewsDefaults, {{"viewFolder", folder}});
}
// MeshLab's own filters (filter_layer): remove the current layer; make layer n the current one.
const char* const kDeleteCurrentLayer = " <filter name=\"Delete Current Mesh\">\n </filter>\n";
std::string make_current(int layer) {
    return " <filter name=\"Change the current layer\">\n  <Param type=\"RichMesh\" name=\"layer\" value=\"" +
           std::to_string(layer) + "\"/>\n </filter>\n";
}
std::string measure(const std::string& shape) {
    return filter("PicoScan: Measure Sphere or Plane", kMeasureDefaults, {{"shape", shape == "sphere" ? "0" : "1"}});
}

std::string section(const std::map<std::string, std::string>& overrides) {
    return filter("PicoScan: Fit Cross-section", kSectionDefaults, overrides);
}

struct ServerRun {
    int exit_code = -1;
    std::string log;
};

// Runs meshlabserver from the private prefix on a script; `arguments` are its -i/-o options.
ServerRun run_meshlabserver(const std::string& directory, const std::string& filters, const std::string& arguments) {
    const std::string script = directory + "/script.mlx";
    std::ofstream(script) << "<!DOCTYPE FilterScript>\n<FilterScript>\n" << filters << "</FilterScript>\n";
    ServerRun run;
    run.exit_code = run_command("cd '" + directory + "' && xvfb-run -a -s '-screen 0 1024x768x24' '" MESHLAB_TEST_PREFIX
                                "/bin/meshlabserver' -s script.mlx " + arguments,
                                &run.log);
    return run;
}

std::string write_file(const std::string& path, const std::string& text) {
    std::ofstream(path) << text;
    return path;
}

std::string read_text(const std::string& path) {
    std::ifstream in(path);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// Saves `mesh_file` as `out` through MeshLab's GUI under Xvfb: File > Export Mesh As and MeshLab's
// PLY options dialog, answered by the test-only plugin in the prefix, which unticks the boxes named
// in `untick` (comma-separated). Returns the dialog's boxes as it opened, one "check_iom_NAME
// enabled E checked C" line each, then "exported" once MeshLab's save returned.
std::string save_in_meshlab_gui(const std::string& directory, const std::string& mesh_file, const std::string& out,
                                const std::string& untick) {
    const std::string report = directory + "/export_report.txt", home = directory + "/gui_home";
    std::filesystem::remove(report);
    std::filesystem::create_directories(home);  // MeshLab's settings stay in the test's folder
    std::string log;
    run_command("cd '" + directory + "' && HOME='" + home + "' PICOSCAN_MESHLAB_EXPORT_AS='" + out +
                    "' PICOSCAN_MESHLAB_EXPORT_REPORT='" + report + "' PICOSCAN_MESHLAB_EXPORT_UNTICK='" + untick +
                    "' xvfb-run -a -s '-screen 0 1280x960x24' sh -c '\"$0\" \"$1\" > gui.log 2>&1 & pid=$!; "
                    "for i in $(seq 240); do grep -q exported \"$2\" 2>/dev/null && break; sleep 0.5; done; "
                    "kill $pid; wait $pid' '" MESHLAB_TEST_PREFIX "/bin/meshlab' '" + mesh_file + "' '" + report + "'",
                &log);
    return read_text(report);
}

// A run refused with the one line of a layer that no view file holds, having written nothing.
void expect_no_pixel_grid(const ServerRun& run, const std::string& layer_file, const std::string& folder,
                          const std::string& never_written) {
    EXPECT_NE(run.exit_code, 0);
    EXPECT_NE(run.log.find(layer_file + ": this layer has no camera pixel grid (its file is not a PicoScan view, and no "
                           "PicoScan view in " + folder + " holds its points)"),
              std::string::npos)
        << run.log;
    EXPECT_FALSE(std::ifstream(never_written).good()) << never_written;
}

// The numbers after `label` in a log line such as "radius 30.0012 mm".
std::vector<double> numbers_after(const std::string& log, const std::string& label, int count) {
    const size_t at = log.rfind(label);
    if (at == std::string::npos) return {};
    std::istringstream stream(log.substr(at + label.size()));
    std::vector<double> values(count);
    for (double& value : values)
        if (!(stream >> value)) return {};
    return values;
}

double max_distance(const std::vector<cv::Vec3f>& a, const std::vector<cv::Vec3f>& b) {
    double worst = 0;
    for (size_t i = 0; i < std::min(a.size(), b.size()); ++i) worst = std::max(worst, double(cv::norm(a[i] - b[i])));
    return worst;
}

const cv::Vec3d kSphereCentre{8, -5, 410};
const double kSphereRadius = 35;

}  // namespace

// simulate -> (captures saved) -> reconstruct from the capture set -> clean -> measure, then
// a grid mesh of the same captures saved as STL.
TEST(MeshlabPlugin, SimulateReconstructCleanMeasureMatchGroundTruthAndCli) {
    const std::string directory = make_temp_dir("meshlab_sphere");
    const std::string scene = write_file(directory + "/sphere.yml",
                                         "spheres:\n  - { centre: [8, -5, 410], radius_mm: 35 }\n");
    const std::string captures = directory + "/captures";
    const std::string filters =
        simulate({{"sceneFile", scene}, {"shifts", "4"}, {"saveCaptureFolder", captures}}) +
        reconstruct({{"captureFolder", captures}, {"calibrationFile", captures + "/calibration.yml"}}) + clean() +
        measure("sphere") +
        reconstruct({{"captureFolder", captures}, {"calibrationFile", captures + "/calibration.yml"}, {"output", "1"},
                     {"meshStep", "2"}});
    const ServerRun run = run_meshlabserver(
        directory, filters, "-o simulated.ply -l 0 -m vc vn vq -o cleaned.ply -l 1 -m vc vn vq -o grid.stl -l 2");
    ASSERT_EQ(run.exit_code, 0) << run.log;

    // The plugin's simulated layer is the CLI's reconstruction of the saved captures, point for point.
    std::string cli_log;
    ASSERT_EQ(run_command(test_support::cli_path() + " reconstruct --calibration " + captures + "/calibration.yml --captures " +
                              captures + " --out " + directory + "/cli.ply --mesh " + directory + "/cli.stl --mesh-step 2",
                          &cli_log),
              0)
        << cli_log;
    const Mesh simulated = read_ply(directory + "/simulated.ply");
    const Mesh cli = read_ply(directory + "/cli.ply");
    ASSERT_GT(cli.vertices.size(), 100000u);
    ASSERT_EQ(simulated.vertices.size(), cli.vertices.size());
    EXPECT_LT(max_distance(simulated.vertices, cli.vertices), 1e-4);

    // Cleaning removed what the log says, and the sphere is the scene's sphere.
    const Mesh cleaned = read_ply(directory + "/cleaned.ply");
    const std::vector<double> removed = numbers_after(run.log, "removed", 1);
    ASSERT_EQ(removed.size(), 1u) << run.log;
    EXPECT_EQ(cleaned.vertices.size() + size_t(removed[0]), cli.vertices.size());
    EXPECT_LT(removed[0], 0.05 * cli.vertices.size());
    const SphereFit fit = fit_sphere(cleaned.vertices);
    std::printf("sphere: %zu points, %zu after cleaning; radius %.4f mm (truth %.1f), centre error %.4f mm, RMS %.4f mm\n",
                cli.vertices.size(), cleaned.vertices.size(), fit.radius_mm, kSphereRadius,
                cv::norm(fit.centre - kSphereCentre), fit.rms_mm);
    EXPECT_NEAR(fit.radius_mm, kSphereRadius, 0.05);
    EXPECT_LT(cv::norm(fit.centre - kSphereCentre), 0.1);
    EXPECT_LT(fit.rms_mm, 0.05);
    // Measure logged the same fit.
    const std::vector<double> logged_radius = numbers_after(run.log, "radius", 1);
    ASSERT_EQ(logged_radius.size(), 1u) << run.log;
    EXPECT_NEAR(logged_radius[0], fit.radius_mm, 1e-3);

    // The grid mesh layer, saved by MeshLab as STL, has the CLI's triangles.
    const Mesh grid = read_stl(directory + "/grid.stl");
    const Mesh cli_grid = read_stl(directory + "/cli.stl");
    ASSERT_GT(cli_grid.faces.size(), 50000u);
    EXPECT_EQ(grid.faces.size(), cli_grid.faces.size());
    EXPECT_EQ(grid.vertices.size(), cli_grid.vertices.size());
}

TEST(MeshlabPlugin, MeasurePlaneOfSimulatedPlate) {
    const std::string directory = make_temp_dir("meshlab_plane");
    // A plate tilted 20 degrees about the camera's y axis.
    const double angle = 20 * CV_PI / 180;
    const cv::Vec3d normal(std::sin(angle), 0, -std::cos(angle));
    char text[200];
    std::snprintf(text, sizeof text, "planes:\n  - { point: [0, 0, 420], normal: [%.9f, 0, %.9f] }\n", normal[0], normal[2]);
    const std::string scene = write_file(directory + "/plate.yml", text);
    const ServerRun run = run_meshlabserver(directory, simulate({{"sceneFile", scene}, {"shifts", "4"}}) + measure("plane"),
                                            "-o plate.ply");
    ASSERT_EQ(run.exit_code, 0) << run.log;
    // Ground truth for the saved points: their distances to the scene's plane.
    const Mesh plate = read_ply(directory + "/plate.ply");
    ASSERT_GT(plate.vertices.size(), 1000000u);
    double sum_squares = 0, x_min = 1e9, x_max = -1e9;
    for (const cv::Vec3f& p : plate.vertices) {
        const double distance = (cv::Vec3d(p) - cv::Vec3d(0, 0, 420)).dot(normal);
        sum_squares += distance * distance;
        x_min = std::min(x_min, double(p[0])), x_max = std::max(x_max, double(p[0]));
    }
    const double truth_rms = std::sqrt(sum_squares / plate.vertices.size());
    std::printf("plate: %zu points, x %.1f..%.1f mm, RMS distance to the true plane %.4f mm\n", plate.vertices.size(),
                x_min, x_max, truth_rms);
    EXPECT_LT(truth_rms, 0.05);
    EXPECT_GT(x_max - x_min, 200);
    const std::vector<double> fitted = numbers_after(run.log, "normal", 3);
    const std::vector<double> rms = numbers_after(run.log, "RMS", 1);
    ASSERT_EQ(fitted.size(), 3u) << run.log;
    ASSERT_EQ(rms.size(), 1u) << run.log;
    // atan2 of |cross| and dot: acos loses precision near 0 degrees.
    const cv::Vec3d measured(fitted[0], fitted[1], fitted[2]);
    const double angle_error_deg =
        std::atan2(cv::norm(measured.cross(normal)), std::abs(measured.dot(normal))) * 180 / CV_PI;
    std::printf("plate: normal error %.4f deg, RMS %.4f mm\n", angle_error_deg, rms[0]);
    EXPECT_LT(angle_error_deg, 0.01);
    EXPECT_LT(rms[0], 0.05);
}

TEST(MeshlabPlugin, ClearErrorsForMissingFolderWrongCalibrationAndPlainLayers) {
    const std::string directory = make_temp_dir("meshlab_errors");
    const std::string captures = directory + "/captures";
    // A capture set and its calibration, plus a calibration for another camera size.
    ServerRun run = run_meshlabserver(directory, simulate({{"shifts", "3"}, {"saveCaptureFolder", captures}}), "");
    ASSERT_EQ(run.exit_code, 0) << run.log;
    Calibration other = seed_rig_calibration();
    other.camera_size = {800, 600};
    const std::string wrong_calibration = directory + "/other.yml";
    write_calibration(other, wrong_calibration);

    run = run_meshlabserver(directory, reconstruct({{"captureFolder", directory + "/missing"},
                                                    {"calibrationFile", captures + "/calibration.yml"}}),
                            "-o never.ply");
    EXPECT_NE(run.exit_code, 0);
    EXPECT_NE(run.log.find(directory + "/missing: capture folder not found"), std::string::npos) << run.log;

    run = run_meshlabserver(directory, reconstruct({{"captureFolder", captures}, {"calibrationFile", wrong_calibration}}),
                            "-o never.ply");
    EXPECT_NE(run.exit_code, 0);
    EXPECT_NE(run.log.find("000_white.png: image is 1600x1200 but the calibration's camera_size is 800x600"),
              std::string::npos)
        << run.log;

    // Simulate refuses to write captures into a folder that holds files, before any work.
    run = run_meshlabserver(directory, simulate({{"shifts", "3"}, {"saveCaptureFolder", captures}}), "-o never.ply");
    EXPECT_NE(run.exit_code, 0);
    EXPECT_NE(run.log.find(captures + ": output folder exists and is not empty"), std::string::npos) << run.log;

    // A layer read from a plain PLY has no pixel grid: Clean says so and changes nothing.
    Mesh plain;
    plain.vertices = {{0, 0, 400}, {1, 0, 400}, {0, 1, 400}, {1, 1, 401}};
    write_ply(plain, directory + "/plain.ply");
    run = run_meshlabserver(directory, clean(), "-i plain.ply -o never.ply");
    EXPECT_NE(run.exit_code, 0);
    EXPECT_NE(run.log.find("this layer has no camera pixel grid"), std::string::npos) << run.log;
    EXPECT_FALSE(std::ifstream(directory + "/never.ply").good());
}

namespace {

// The layers MeshLab saved in a project (.mlp), in layer order: mesh file and transform.
struct ProjectLayer {
    std::string file;
    cv::Matx44d transform;
};
std::vector<ProjectLayer> read_project(const std::string& path) {
    std::ifstream stream(path);
    const std::string text((std::istreambuf_iterator<char>(stream)), std::istreambuf_iterator<char>());
    const std::string folder = path.substr(0, path.rfind('/') + 1);
    std::vector<ProjectLayer> layers;
    for (size_t at = text.find("<MLMesh "); at != std::string::npos; at = text.find("<MLMesh ", at + 1)) {
        ProjectLayer layer;
        const size_t name = text.find("filename=\"", at) + 10;
        const std::string file = text.substr(name, text.find('"', name) - name);
        layer.file = file.front() == '/' ? file : folder + file;
        std::istringstream numbers(text.substr(text.find("<MLMatrix44>", at) + 12));
        for (int i = 0; i < 16; ++i) numbers >> layer.transform.val[i];
        layers.push_back(layer);
    }
    return layers;
}

// Edges counted on the file as saved: a closed 2-manifold has every edge in exactly two faces.
struct EdgeCount {
    size_t edges = 0, border = 0, non_manifold = 0;
};
EdgeCount count_edges(const Mesh& mesh) {
    std::map<std::pair<int, int>, int> uses;
    for (const cv::Vec3i& face : mesh.faces)
        for (int k = 0; k < 3; ++k) ++uses[std::minmax(face[k], face[(k + 1) % 3])];
    EdgeCount count;
    count.edges = uses.size();
    for (const auto& [edge, faces] : uses) count.border += faces == 1, count.non_manifold += faces > 2;
    return count;
}

cv::Matx44d inverse_rigid(const cv::Matx44d& t) {
    const cv::Matx33d r = t.get_minor<3, 3>(0, 0).t();
    const cv::Vec3d shift = -(r * cv::Vec3d(t(0, 3), t(1, 3), t(2, 3)));
    cv::Matx44d inverse = cv::Matx44d::eye();
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) inverse(i, j) = r(i, j);
        inverse(i, 3) = shift[i];
    }
    return inverse;
}

// The rigid transform nearest to one read from a project: MeshLab writes 6 significant digits,
// and the rounded rotation, no longer orthonormal, would read as up to 0.06 degrees of turn in
// pose_difference (its angle comes from the trace).
cv::Matx44d nearest_rigid(const cv::Matx44d& t) {
    const cv::SVD svd(cv::Mat(cv::Matx33d(t.get_minor<3, 3>(0, 0))));
    const cv::Mat rotation = svd.u * svd.vt;
    cv::Matx44d rigid = t;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) rigid(i, j) = rotation.at<double>(i, j);
    return rigid;
}

}  // namespace

// Nine turntable views of the mechanical part -> Align Layers -> Fuse and Mesh (Poisson), saved
// as a project (the transforms) and the fused layer as PLY and STL.
TEST(MeshlabPlugin, AlignAndFuseTurntableViewsIntoWatertightPart) {
    const std::string directory = make_temp_dir("meshlab_turntable");
    const std::vector<cv::Matx44d> part_to_camera = turntable_part_poses(TurntablePlan{});
    std::string filters;
    for (size_t i = 0; i < part_to_camera.size(); ++i)
        filters += simulate({{"partView", std::to_string(i)}, {"shifts", "16"}, {"fullScale", "250"},
                             {"minModulation", "15"}, {"blur", "0.5"}}) +
                   clean();
    filters += align() + fuse();
    const std::string fused_layer = std::to_string(part_to_camera.size());
    const ServerRun run = run_meshlabserver(directory, filters,
                                            "-w project.mlp -o fused.ply -l " + fused_layer + " -o fused.stl -l " + fused_layer);
    ASSERT_EQ(run.exit_code, 0) << run.log;

    // Each layer's transform is its true pose relative to the first view.
    const std::vector<ProjectLayer> layers = read_project(directory + "/project.mlp");
    ASSERT_EQ(layers.size(), part_to_camera.size() + 1) << run.log;
    double worst_rotation = 0, worst_translation = 0;
    for (size_t i = 0; i < part_to_camera.size(); ++i) {
        const cv::Matx44d truth = part_to_camera[0] * inverse_rigid(part_to_camera[i]);
        // Measured at the part's middle (part frame z = 16 mm), in view i's coordinates.
        const cv::Vec4d middle = part_to_camera[i] * cv::Vec4d(0, 0, 16, 1);
        const PoseDifference error = pose_difference(truth, layers[i].transform, cv::Vec3d(middle[0], middle[1], middle[2]));
        worst_rotation = std::max(worst_rotation, error.rotation_deg);
        worst_translation = std::max(worst_translation, error.translation_mm);
    }
    const std::vector<double> residuals = numbers_after(run.log, "residual", 1);
    ASSERT_EQ(residuals.size(), 1u) << run.log;
    std::printf("alignment of %zu views: worst pose error %.3f deg, %.3f mm; last layer's residual %.4f mm\n",
                part_to_camera.size(), worst_rotation, worst_translation, residuals[0]);
    EXPECT_LT(residuals[0], 0.1);
    EXPECT_LT(worst_rotation, 0.15);
    EXPECT_LT(worst_translation, 0.1);
    EXPECT_NE(run.log.find("PicoScan aligned " + std::to_string(part_to_camera.size()) + " layers"), std::string::npos);
    // Overlap is a share of a layer's points: at most 100 % (the core's ratio can pass 1), as the CLI prints it.
    for (size_t at = run.log.find("overlap "); at != std::string::npos; at = run.log.find("overlap ", at + 1)) {
        std::istringstream share(run.log.substr(at + 8));
        double percent = -1;
        if (share >> percent) {
            EXPECT_LE(percent, 100.0) << run.log.substr(at, 40);
        }
    }

    // The fused mesh, as MeshLab saved it: closed, and on the true part.
    for (const std::string file : {"fused.ply", "fused.stl"}) {
        const Mesh fused = read_mesh(directory + "/" + file);
        const EdgeCount edges = count_edges(fused);
        std::printf("%s: %zu vertices, %zu faces, %zu edges, %zu border, %zu non-manifold\n", file.c_str(),
                    fused.vertices.size(), fused.faces.size(), edges.edges, edges.border, edges.non_manifold);
        EXPECT_GT(fused.faces.size(), 5000u) << file;
        EXPECT_EQ(edges.border, 0u) << file;
        EXPECT_EQ(edges.non_manifold, 0u) << file;
        EXPECT_EQ(2 * edges.edges, 3 * fused.faces.size()) << file;
    }
    // The part's bottom face stood on the turntable and was never seen; Poisson closes it with a
    // smooth cap. Only vertices with measured points nearby (the saved layers through their saved
    // transforms) are judged against the true part.
    const Mesh fused = read_ply(directory + "/fused.ply");
    const MeshCheck check = check_mesh(fused);
    std::printf("core check of fused.ply: %s\n", check.summary().c_str());
    EXPECT_EQ(check.components, 1u);
    Mesh data;  // measured points as degenerate triangles, for the distance grid
    for (size_t i = 0; i < part_to_camera.size(); ++i) {
        const Mesh view = read_ply(layers[i].file);
        for (size_t k = 0; k < view.vertices.size(); k += 3) {
            const cv::Vec4d p = layers[i].transform * cv::Vec4d(view.vertices[k][0], view.vertices[k][1], view.vertices[k][2], 1);
            data.vertices.emplace_back(float(p[0]), float(p[1]), float(p[2]));
            const int index = int(data.vertices.size()) - 1;
            data.faces.emplace_back(index, index, index);
        }
    }
    const test_support::MeshDistance distance_to_data(data, 1.0);
    const Mesh truth = transformed(mechanical_part(), part_to_camera[0]);
    const test_support::MeshDistance distance_to_part(truth, 5.0);
    std::vector<double> distances;
    for (const cv::Vec3f& vertex : fused.vertices)
        if (distance_to_data(cv::Vec3d(vertex)) <= 0.5) distances.push_back(distance_to_part(cv::Vec3d(vertex)));
    ASSERT_GT(distances.size(), fused.vertices.size() / 2);
    std::sort(distances.begin(), distances.end());
    double mean = 0;
    for (double distance : distances) mean += distance / double(distances.size());
    const double p95 = distances[distances.size() * 95 / 100];
    std::printf("fused mesh vs true part over the %zu of %zu vertices near measured points: mean %.4f mm, p95 %.4f mm, "
                "max %.4f mm\n",
                distances.size(), fused.vertices.size(), mean, p95, distances.back());
    EXPECT_LT(mean, 0.025);
    EXPECT_LT(p95, 0.07);
}

// Align refuses plain layers, naming them.
TEST(MeshlabPlugin, AlignNeedsPicoScanLayers) {
    const std::string directory = make_temp_dir("meshlab_align_plain");
    Mesh plain;
    plain.vertices = {{0, 0, 400}, {1, 0, 400}, {0, 1, 400}, {1, 1, 401}};
    write_ply(plain, directory + "/plain.ply");
    const ServerRun run = run_meshlabserver(directory, simulate({{"shifts", "3"}}) + align(), "-i plain.ply -o never.ply");
    EXPECT_NE(run.exit_code, 0);
    EXPECT_NE(run.log.find("plain.ply: this layer has no camera pixel grid"), std::string::npos) << run.log;
}

// Front and back of the part do not overlap: Align fails, names the layer and changes nothing.
TEST(MeshlabPlugin, AlignReportsLayersThatCannotBeAligned) {
    const std::string directory = make_temp_dir("meshlab_align_apart");
    const ServerRun run = run_meshlabserver(
        directory,
        simulate({{"partView", "0"}, {"shifts", "8"}, {"fullScale", "250"}, {"minModulation", "15"}}) +
            simulate({{"partView", "4"}, {"shifts", "8"}, {"fullScale", "250"}, {"minModulation", "15"}}) + align(),
        "-o never.ply");
    EXPECT_NE(run.exit_code, 0);
    EXPECT_NE(run.log.find("Align Layers: 1 of 2 layers could not be aligned, no transform changed (Part view 4: "),
              std::string::npos)
        << run.log;
}

// The real SLMaster monocular set reconstructs through the plugin to the CLI's cloud.
TEST(MeshlabPlugin, RealSlmasterSetMatchesCli) {
    PICOSCAN_REQUIRE_DATASETS();
    const std::string root = test_support::datasets_dir() + "/slmaster-sinuscgc/monocularCamera";
    const std::string directory = make_temp_dir("meshlab_slmaster");
    const ServerRun run = run_meshlabserver(
        directory,
        reconstruct({{"captureFolder", root + "/L"}, {"calibrationFile", root + "/caliInfo.yml"}, {"sequence", "1"}}),
        "-o plugin.ply -m vc vn vq");
    ASSERT_EQ(run.exit_code, 0) << run.log;
    std::string cli_log;
    const std::string cli = test_support::cli_path();
    ASSERT_EQ(run_command(cli + " manifest --preset slmaster-cgc --projector 1920x1080 --out " + directory +
                              "/sequence.json && " + cli + " reconstruct --calibration " + root +
                              "/caliInfo.yml --captures " + root + "/L --manifest " + directory + "/sequence.json --out " +
                              directory + "/cli.ply",
                          &cli_log),
              0)
        << cli_log;
    const Mesh plugin = read_ply(directory + "/plugin.ply");
    const Mesh reference = read_ply(directory + "/cli.ply");
    std::printf("SLMaster through MeshLab: %zu points, CLI %zu points, max distance %.2g mm\n", plugin.vertices.size(),
                reference.vertices.size(), max_distance(plugin.vertices, reference.vertices));
    ASSERT_GT(reference.vertices.size(), 180000u);
    ASSERT_EQ(plugin.vertices.size(), reference.vertices.size());
    EXPECT_LT(max_distance(plugin.vertices, reference.vertices), 1e-4);
    ASSERT_EQ(plugin.colours.size(), reference.colours.size());
    EXPECT_TRUE(plugin.colours == reference.colours);
}

// Range checks are the core's (validate); the message names the MeshLab parameter the user set,
// and nothing runs.
TEST(MeshlabPlugin, RangeErrorsNameMeshlabParameters) {
    const std::string directory = make_temp_dir("meshlab_ranges");
    Mesh plain;
    plain.vertices = {{0, 0, 400}, {1, 0, 400}, {0, 1, 400}, {1, 1, 401}};
    write_ply(plain, directory + "/plain.ply");
    const std::vector<std::tuple<std::string, std::string, std::string>> cases{
        {simulate({{"minModulation", "-1"}}), "", "PicoScan: Simulate Scan error: minModulation: must be 0..255"},
        {simulate({{"shifts", "2"}}), "", "PicoScan: Simulate Scan error: shifts: must be 3..64"},
        {simulate({{"blur", "30"}}), "", "PicoScan: Simulate Scan error: blur: must be 0..20"},
        {simulate({{"output", "1"}, {"meshStep", "0"}}), "", "PicoScan: Simulate Scan error: meshStep: must be 1..64"},
        {clean({{"windowPx", "11"}}), "-i plain.ply", "PicoScan: Clean Scan error: windowPx: must be 1..10"},
        {align({{"sampleSpacing", "0"}}), "-i plain.ply", "PicoScan: Align Layers error: sampleSpacing: must be 0.1..20"},
        {fuse({{"poissonDistance", "0"}}), "-i plain.ply",
         "PicoScan: Fuse and Mesh error: poissonDistance: must be 0.001..10"},
        {fuse({{"method", "1"}, {"fill", "1"}}), "-i plain.ply",
         "PicoScan: Fuse and Mesh error: fill: table closes the Poisson surface: it needs method poisson"},
        {align({{"turntableAxisDirection", "0 1 0"}}), "-i plain.ply",
         "PicoScan: Align Layers error: turntableAxisDirection: is used in mode 'Turntable axis' only"},
        {align({{"mode", "3"}}), "-i plain.ply",
         "PicoScan: Align Layers error: turntableAxisDirection: must not be zero in mode 'Turntable axis'"},
        // A script may give any number for a choice or a distance: neither runs a guess.
        {fuse({{"method", "7"}}), "-i plain.ply", "PicoScan: Fuse and Mesh error: method: must be 0..1, is 7"},
        {section({{"at", "nan"}}), "-i plain.ply", "PicoScan: Fit Cross-section error: at: must be a finite position in mm"},
    };
    for (const auto& [script, input, message] : cases) {
        const ServerRun run = run_meshlabserver(directory, script, input + " -o never.ply");
        EXPECT_NE(run.exit_code, 0) << message;
        EXPECT_NE(run.log.find(message), std::string::npos) << run.log;
        // The core's field names ("decode.min_modulation") never reach the user.
        for (const char* field : {"decode.", "patterns.", "camera.", "cleaning.", "registration.", "mesh."})
            EXPECT_EQ(run.log.find(std::string("error: ") + field), std::string::npos) << run.log;
        EXPECT_EQ(run.log.find("PicoScan simulate"), std::string::npos) << "work started despite " << message;
    }
    EXPECT_FALSE(std::ifstream(directory + "/never.ply").good());
}

// A view written by the CLI, opened in MeshLab (which drops its pixels and camera), cleans
// exactly as 'picoscan clean' cleans the same file: the layer takes both from its file again.
TEST(MeshlabPlugin, ViewPlyOpenedInMeshlabCleansAsCli) {
    const std::string directory = make_temp_dir("meshlab_reopen_clean");
    const std::string scene = write_file(directory + "/sphere.yml",
                                         "spheres:\n  - { centre: [8, -5, 410], radius_mm: 35 }\n");
    const std::string captures = directory + "/captures";
    ServerRun run = run_meshlabserver(directory, simulate({{"sceneFile", scene}, {"shifts", "4"}, {"saveCaptureFolder", captures}}), "");
    ASSERT_EQ(run.exit_code, 0) << run.log;
    const std::string cli = test_support::cli_path();
    std::string cli_log;
    ASSERT_EQ(run_command(cli + " reconstruct --calibration " + captures + "/calibration.yml --captures " + captures +
                              " --out " + directory + "/view.ply && " + cli + " clean " + directory + "/view.ply --out " +
                              directory + "/cli_clean.ply",
                          &cli_log),
              0)
        << cli_log;
    run = run_meshlabserver(directory, clean(), "-i view.ply -o plugin_clean.ply -m vc vn vq");
    ASSERT_EQ(run.exit_code, 0) << run.log;
    const Mesh view = read_ply(directory + "/view.ply");
    const Mesh by_cli = read_ply(directory + "/cli_clean.ply");
    const Mesh by_plugin = read_ply(directory + "/plugin_clean.ply");
    const std::vector<double> removed = numbers_after(run.log, "removed", 1);
    ASSERT_EQ(removed.size(), 1u) << run.log;
    std::printf("reopened view: %zu points; plugin clean keeps %zu (removed %.0f), CLI clean keeps %zu\n",
                view.vertices.size(), by_plugin.vertices.size(), removed[0], by_cli.vertices.size());
    EXPECT_GT(removed[0], 0);
    EXPECT_EQ(by_plugin.vertices.size() + size_t(removed[0]), view.vertices.size());
    ASSERT_EQ(by_plugin.vertices.size(), by_cli.vertices.size());
    EXPECT_LT(max_distance(by_plugin.vertices, by_cli.vertices), 1e-4);

    // A plain copy with one point fewer (as deleting a point in MeshLab and saving leaves it): its
    // points are the view's, in order, so its pixels and camera come from view.ply beside it.
    Mesh edited = view;
    edited.vertices.pop_back();
    edited.normals.pop_back();
    if (!edited.colours.empty()) edited.colours.pop_back();
    write_ply(edited, directory + "/edited.ply");
    run = run_meshlabserver(directory, clean(), "-i edited.ply -o edited_clean.ply");
    EXPECT_EQ(run.exit_code, 0) << run.log;
    EXPECT_NE(run.log.find("edited.ply: pixel grid and camera taken from the view file " + directory + "/view.ply"),
              std::string::npos)
        << run.log;
    // Built to fool it: one point moved by 0.01 mm. No view holds the layer's points: refused, naming why.
    Mesh moved = view;
    moved.vertices[moved.vertices.size() / 2][2] += 0.01f;
    write_ply(moved, directory + "/moved.ply");
    run = run_meshlabserver(directory, clean(), "-i moved.ply -o never.ply");
    expect_no_pixel_grid(run, "moved.ply", directory, directory + "/never.ply");
}

// A scan layer saved in a project by MeshLab's own save (meshlabserver -w) keeps its pixels and
// camera, with the lens's k3 (MeshLab's camera holds four distortion coefficients): reopened with
// its view file deleted, it cleans as the CLI cleans that view, and Save Views writes the view's
// whole camera again. Saved by -o with a mask that leaves the camera and normals out, the layer is
// refused with the reason rather than cleaned with a guessed camera.
TEST(MeshlabPlugin, ScanLayerKeepsItsGridInAProjectAndIsRefusedWithoutItsCamera) {
    const std::string directory = make_temp_dir("meshlab_scan_project");
    const std::string rig = directory + "/rig.yml";
    Calibration calibration = test_support::half_resolution_seed_rig();  // 800 x 600: a quarter of the work
    calibration.camera_distortion.at<double>(4) = 0.35;                 // k3, as OpenCV's calibration fits it
    write_calibration(calibration, rig);
    ServerRun run = run_meshlabserver(directory, simulate({{"partView", "0"}, {"calibrationFile", rig}}) + save_views(directory + "/views"),
                                      "-w project.mlp -o scan.ply -m vc vq vt");
    ASSERT_EQ(run.exit_code, 0) << run.log;
    const std::string view = directory + "/views/Part_view_0.ply";
    const cv::Mat lens = read_view_ply(view).camera_distortion;
    ASSERT_EQ(lens.total(), 5u);
    EXPECT_NEAR(lens.at<double>(4), 0.35, 1e-9);
    std::string cli_log;
    ASSERT_EQ(run_command(test_support::cli_path() + " clean " + view + " --out " + directory + "/cli_clean.ply", &cli_log), 0)
        << cli_log;
    std::filesystem::remove(view);
    run = run_meshlabserver(directory, clean() + save_views(directory + "/again"), "-p project.mlp -o cleaned.ply -m vn");
    ASSERT_EQ(run.exit_code, 0) << run.log;
    EXPECT_EQ(run.log.find("taken from the view file"), std::string::npos) << run.log;
    const cv::Mat reopened_lens = read_view_ply(directory + "/again/Part_view_0_out.ply").camera_distortion;
    ASSERT_EQ(reopened_lens.total(), 5u);
    for (int i = 0; i < 5; ++i)
        EXPECT_NEAR(reopened_lens.at<double>(i), lens.at<double>(i), 1e-6 + 1e-6 * std::abs(lens.at<double>(i))) << i;
    const Mesh by_plugin = read_ply(directory + "/cleaned.ply"), by_cli = read_ply(directory + "/cli_clean.ply");
    const std::vector<double> removed = numbers_after(run.log, "removed", 1);
    ASSERT_EQ(removed.size(), 1u) << run.log;
    std::printf("scan layer saved by meshlabserver -w, its view deleted: clean removed %.0f and kept %zu points, the CLI "
                "keeps %zu, max distance %.2g mm\n",
                removed[0], by_plugin.vertices.size(), by_cli.vertices.size(), max_distance(by_plugin.vertices, by_cli.vertices));
    EXPECT_GT(removed[0], 0);
    ASSERT_EQ(by_plugin.vertices.size(), by_cli.vertices.size());
    EXPECT_LT(max_distance(by_plugin.vertices, by_cli.vertices), 1e-4);

    run = run_meshlabserver(directory, clean(), "-i scan.ply -o never.ply");
    EXPECT_NE(run.exit_code, 0);
    EXPECT_NE(run.log.find("scan.ply: this layer has pixel coordinates but no camera"), std::string::npos) << run.log;
    EXPECT_FALSE(std::ifstream(directory + "/never.ply").good());

    // A lens MeshLab's camera cannot hold (OpenCV's rational model: k4 as well): the layer gets no
    // MeshLab camera, so reopened without its view file it is refused, not given a lens without k4.
    const std::string rational = directory + "/rational";
    std::filesystem::create_directories(rational);
    ScanView rational_view = read_view_ply(directory + "/again/Part_view_0_out.ply");
    cv::Mat eight = cv::Mat::zeros(1, 8, CV_64F);
    lens.reshape(1, 1).copyTo(eight.colRange(0, 5));
    eight.at<double>(5) = 0.02;
    rational_view.camera_distortion = eight;
    write_view_ply(rational_view, rational + "/view.ply");
    run = run_meshlabserver(rational, clean(), "-i view.ply -w project.mlp");
    ASSERT_EQ(run.exit_code, 0) << run.log;
    std::filesystem::remove(rational + "/view.ply");
    run = run_meshlabserver(rational, clean(), "-p project.mlp -o never.ply");
    EXPECT_NE(run.exit_code, 0);
    EXPECT_NE(run.log.find("view_out.ply: this layer has pixel coordinates but no camera"), std::string::npos) << run.log;
    EXPECT_FALSE(std::ifstream(rational + "/never.ply").good());
}

// A layer as MeshLab's GUI saves it with its default PLY options (File > Save Project asks for each
// new layer's file): points, normals, quality, the pixels as texture_u/texture_v and MeshLab's camera
// element (focal, centre, viewport, no PicoScan view beside it). Reopened, it cleans as the CLI
// cleans the view it came from: the camera saved with the layer is enough.
TEST(MeshlabPlugin, LayerSavedWithMeshlabsCameraCleansAsCli) {
    const std::string directory = make_temp_dir("meshlab_gui_saved_layer");
    test_support::two_placement_scan(test_support::PlacementPart::GreyMechanical);  // the shared cached views
    const std::string view_file =
        std::string(PICOSCAN_TEST_CACHE_DIR) + "/half-v1-grey-mechanical-standing/view_0.ply";
    const ScanView view = read_view_ply(view_file);
    // `shift` moves every point's pixel along x: built to fool it, a camera that does not see the points there.
    const auto meshlab_ply = [&view](int shift) {
    std::ostringstream ply;
    ply << "ply\nformat ascii 1.0\nelement camera 1\n";
    for (const char* name : {"view_px", "view_py", "view_pz", "x_axisx", "x_axisy", "x_axisz", "y_axisx", "y_axisy",
                             "y_axisz", "z_axisx", "z_axisy", "z_axisz", "focal", "scalex", "scaley", "centerx",
                             "centery"})
        ply << "property float " << name << "\n";
    ply << "property int viewportx\nproperty int viewporty\n";
    for (const char* name : {"k1", "k2", "k3", "k4"}) ply << "property float " << name << "\n";
    ply << "element vertex " << view.valid_count() << "\n";
    for (const char* name : {"x", "y", "z", "nx", "ny", "nz", "quality", "texture_u", "texture_v"})
        ply << "property float " << name << "\n";
    ply << "element face 0\nproperty list uchar int vertex_indices\nend_header\n";
    const cv::Matx33d& k = view.camera_matrix;
    ply << std::setprecision(9) << "0 0 0 1 0 0 0 1 0 0 0 1 " << k(0, 0) << " 1 " << k(0, 0) / k(1, 1) << " " << k(0, 2)
        << " " << k(1, 2) << " " << view.points.cols << " " << view.points.rows << " 0 0 0 0\n";
    for (int y = 0; y < view.points.rows; ++y)
        for (int x = 0; x < view.points.cols; ++x) {
            const cv::Vec3f& p = view.points.at<cv::Vec3f>(y, x);
            if (!std::isfinite(p[0])) continue;
            const cv::Vec3f& n = view.normals.at<cv::Vec3f>(y, x);
            ply << p[0] << " " << p[1] << " " << p[2] << " " << n[0] << " " << n[1] << " " << n[2] << " "
                << view.quality.at<float>(y, x) << " " << x + shift << " " << y << "\n";
        }
    return ply.str();
    };
    write_file(directory + "/Part_view_0.ply", meshlab_ply(0));
    ServerRun run = run_meshlabserver(directory, clean(), "-i Part_view_0.ply -o plugin_clean.ply -m vn");
    ASSERT_EQ(run.exit_code, 0) << run.log;
    EXPECT_EQ(run.log.find("taken from the view file"), std::string::npos) << run.log;  // its own camera did it
    std::string cli_log;
    ASSERT_EQ(run_command(test_support::cli_path() + " clean " + view_file + " --out " + directory + "/cli_clean.ply", &cli_log), 0)
        << cli_log;
    const Mesh by_plugin = read_ply(directory + "/plugin_clean.ply"), by_cli = read_ply(directory + "/cli_clean.ply");
    const std::vector<double> removed = numbers_after(run.log, "removed", 1);
    ASSERT_EQ(removed.size(), 1u) << run.log;
    std::printf("layer saved with MeshLab's camera: %d points; plugin clean keeps %zu (removed %.0f), CLI clean of its view "
                "keeps %zu, max distance %.2g mm\n",
                view.valid_count(), by_plugin.vertices.size(), removed[0], by_cli.vertices.size(),
                max_distance(by_plugin.vertices, by_cli.vertices));
    EXPECT_GT(removed[0], 0);
    ASSERT_EQ(by_plugin.vertices.size(), by_cli.vertices.size());
    EXPECT_LT(max_distance(by_plugin.vertices, by_cli.vertices), 1e-4);
    write_file(directory + "/shifted.ply", meshlab_ply(1));
    run = run_meshlabserver(directory, clean(), "-i shifted.ply -o never.ply");
    EXPECT_NE(run.exit_code, 0);
    EXPECT_NE(run.log.find("shifted.ply: this layer has pixel coordinates but no camera"), std::string::npos) << run.log;
    EXPECT_FALSE(std::ifstream(directory + "/never.ply").good());
}

// A project (.mlp) of view PLYs in `directory`, in layer order, each labelled by its file name
// and at the identity transform.
// A project of the files, each layer's transform the identity or the one given.
void write_project(const std::string& path, const std::vector<std::string>& files,
                   const std::vector<cv::Matx44d>& transforms = {}) {
    std::string project = "<!DOCTYPE MeshLabDocument>\n<MeshLabProject>\n <MeshGroup>\n";
    for (size_t i = 0; i < files.size(); ++i) {
        const cv::Matx44d transform = i < transforms.size() ? transforms[i] : cv::Matx44d::eye();
        std::string matrix;
        char number[40];
        for (int r = 0; r < 4; ++r, matrix += "\n")
            for (int c = 0; c < 4; ++c) std::snprintf(number, sizeof number, "%.12g ", transform(r, c)), matrix += number;
        project += "  <MLMesh label=\"" + files[i] + "\" filename=\"" + files[i] + "\" visible=\"1\">\n   <MLMatrix44>\n" +
                   matrix + "</MLMatrix44>\n  </MLMesh>\n";
    }
    write_file(path, project + " </MeshGroup>\n <RasterGroup/>\n</MeshLabProject>\n");
}

namespace {

double mesh_area(const Mesh& mesh) {
    double area = 0;
    for (const cv::Vec3i& face : mesh.faces) {
        const cv::Vec3d a(mesh.vertices[size_t(face[0])]), b(mesh.vertices[size_t(face[1])]), c(mesh.vertices[size_t(face[2])]);
        area += 0.5 * cv::norm((b - a).cross(c - a));
    }
    return area;
}

// Enclosed volume by the divergence theorem (signed tetrahedra to the origin), for a closed mesh.
double mesh_volume(const Mesh& mesh) {
    double volume = 0;
    for (const cv::Vec3i& face : mesh.faces) {
        const cv::Vec3d a(mesh.vertices[size_t(face[0])]), b(mesh.vertices[size_t(face[1])]), c(mesh.vertices[size_t(face[2])]);
        volume += a.dot(b.cross(c)) / 6;
    }
    return std::abs(volume);
}

}  // namespace

// A project saved by MeshLab's own save (meshlabserver -w, no PicoScan step before it) of two
// PicoScan view PLYs opened in MeshLab and aligned: MeshLab's copies of the layers keep each
// point's pixel and the view's camera. The first layer is then saved again from MeshLab's GUI
// (File > Export Mesh As) with its Normal box unticked, as a user may: its normals come back from
// the pixel grid. With the view files deleted, a new meshlabserver on the project cleans, aligns
// and fuses as the first session did. A layer file that lost its pixels is refused, naming the
// layer and what it lacks.
TEST(MeshlabPlugin, SavedProjectReopensAndCleansAlignsFuses) {
    const std::string directory = make_temp_dir("meshlab_saved_project");
    const std::string views = directory + "/views";
    const test_support::TurntableScan& scan = test_support::two_placement_scan(test_support::PlacementPart::GreyMechanical);
    // Copies of two cached views (the shared cache is never touched): the "original" view files.
    std::filesystem::create_directories(views);
    const std::string cache = std::string(PICOSCAN_TEST_CACHE_DIR) + "/half-v1-grey-mechanical-standing";
    for (int i = 0; i < 2; ++i)
        std::filesystem::copy_file(cache + "/view_" + std::to_string(i) + ".ply", views + "/view_" + std::to_string(i) + ".ply");
    const std::string cli_clean = directory + "/cli_clean.ply";
    std::string cli_log;
    ASSERT_EQ(run_command(test_support::cli_path() + " clean " + views + "/view_0.ply --out " + cli_clean, &cli_log), 0) << cli_log;

    ServerRun run = run_meshlabserver(directory, align() + fuse({{"sampleSpacing", "0.6"}}),
                                      "-i views/view_0.ply -i views/view_1.ply -w project.mlp -o fused_first.ply -l 2");
    ASSERT_EQ(run.exit_code, 0) << run.log;
    const std::vector<double> first_fused_points = numbers_after(run.log, "PicoScan fused 2 layers (", 1);
    ASSERT_EQ(first_fused_points.size(), 1u) << run.log;
    EXPECT_EQ(first_fused_points[0], double(scan.views[0].valid_count() + scan.views[1].valid_count()));

    // meshlabserver saved its own copies beside the views (VIEW_out.ply: MeshLab's PLY, not the
    // core's view format) and the project names them. The original views go.
    const std::vector<ProjectLayer> saved = read_project(directory + "/project.mlp");
    ASSERT_EQ(saved.size(), 3u);
    for (int i = 0; i < 2; ++i) {
        EXPECT_EQ(saved[size_t(i)].file, views + "/view_" + std::to_string(i) + "_out.ply");
        EXPECT_THROW(read_view_ply(saved[size_t(i)].file), Error) << saved[size_t(i)].file;
        std::filesystem::remove(views + "/view_" + std::to_string(i) + ".ply");
    }

    // The GUI's PLY dialog for a PicoScan point cloud ticks, by default, everything the plugin needs
    // (MeshLab ticks Normal for point clouds; for a layer with faces it would not). The user unticks
    // Normal; MeshLab writes the pixels and camera without normals, saved over the layer's file.
    const std::string gui_saved = views + "/view_0_gui.ply";
    const std::string dialog = save_in_meshlab_gui(directory, saved[0].file, gui_saved, "check_iom_vertnormal");
    std::printf("MeshLab GUI's PLY save dialog for a PicoScan layer, as it opened:\n%s", dialog.c_str());
    for (const char* box : {"vertnormal", "verttexcoord", "vertquality", "vertcolor", "camera"})
        EXPECT_NE(dialog.find(std::string("check_iom_") + box + " enabled 1 checked 1"), std::string::npos) << box << "\n" << dialog;
    ASSERT_NE(dialog.find("exported"), std::string::npos) << dialog << read_text(directory + "/gui.log");
    const std::string header = read_text(gui_saved).substr(0, 2000);
    EXPECT_EQ(header.find("property float nx"), std::string::npos) << header;
    EXPECT_NE(header.find("property float texture_u"), std::string::npos) << header;
    EXPECT_NE(header.find("element camera 1"), std::string::npos) << header;
    std::filesystem::rename(gui_saved, saved[0].file);

    // A new process on the saved project: the first session's fused layer goes, then Align and
    // Fuse (the first session's inputs: the same result expected), Clean of the first layer, and
    // the views written by Save Views for Project, by default into the project's folder.
    run = run_meshlabserver(directory,
                            std::string(kDeleteCurrentLayer) + align() + fuse({{"sampleSpacing", "0.6"}}) +
                                make_current(0) + clean() + save_views(""),
                            "-p project.mlp -w reopened.mlp -o fused_reopened.ply -l 2 -o cleaned_reopened.ply -l 0 -m vn");
    ASSERT_EQ(run.exit_code, 0) << run.log;
    EXPECT_EQ(run.log.find("taken from the view file"), std::string::npos) << run.log;  // each layer's own file did it
    EXPECT_NE(run.log.find("PicoScan aligned 2 layers"), std::string::npos) << run.log;
    // Every point of the GUI-saved layer got its normal back, once; the other layer kept its own.
    const std::string restored = "view_0_out.ply: saved without normals; " + std::to_string(scan.views[0].valid_count()) +
                                 " normals recomputed from the pixel grid";
    EXPECT_NE(run.log.find(restored), std::string::npos) << run.log;
    EXPECT_EQ(run.log.find("view_1_out.ply: saved without normals"), std::string::npos) << run.log;
    const std::vector<double> removed = numbers_after(run.log, "removed", 1);
    ASSERT_EQ(removed.size(), 1u) << run.log;
    // The view's own normals were made on the grid before the reconstruction dropped some pixels, so
    // next to those the grid's normals now differ a little; elsewhere they are the same.
    ScanView regridded = scan.views[0];
    regridded.normals = cv::Mat();
    estimate_normals(regridded);
    int normals_compared = 0, normals_differing = 0, normals_off_by_a_degree = 0;
    double worst_normal_deg = 0;
    for (int y = 0; y < regridded.points.rows; ++y)
        for (int x = 0; x < regridded.points.cols; ++x) {
            const cv::Vec3f a = scan.views[0].normals.at<cv::Vec3f>(y, x), b = regridded.normals.at<cv::Vec3f>(y, x);
            if (!is_finite_point(scan.views[0].points.at<cv::Vec3f>(y, x)) || !is_finite_point(a) || !is_finite_point(b)) continue;
            ++normals_compared;
            const double angle = std::acos(std::min(1.0, double(a.dot(b)))) * 180 / CV_PI;
            normals_differing += angle > 1e-3;
            normals_off_by_a_degree += angle > 1;
            worst_normal_deg = std::max(worst_normal_deg, angle);
        }
    // Clean of the reopened layer against the CLI's clean of the deleted view (its own normals): the
    // points kept by one and not the other, at most 0.1 % of them.
    const Mesh by_plugin = read_ply(directory + "/cleaned_reopened.ply"), by_cli = read_ply(cli_clean);
    const auto key = [](const cv::Vec3f& p) { return std::make_tuple(p[0], p[1], p[2]); };
    std::set<std::tuple<float, float, float>> kept_by_cli;
    for (const cv::Vec3f& p : by_cli.vertices) kept_by_cli.insert(key(p));
    size_t common = 0;
    for (const cv::Vec3f& p : by_plugin.vertices) common += kept_by_cli.count(key(p));
    const size_t clean_differences = by_plugin.vertices.size() + by_cli.vertices.size() - 2 * common;
    std::printf("normals of the GUI-saved layer recomputed from its grid: %d of %d differ from the view's own, %d by more "
                "than 1 deg, by up to %.2f deg; its clean keeps %zu points, the CLI's clean of the view %zu, %zu kept by "
                "one only\n",
                normals_differing, normals_compared, normals_off_by_a_degree, worst_normal_deg, by_plugin.vertices.size(),
                by_cli.vertices.size(), clean_differences);
    EXPECT_LT(normals_off_by_a_degree, normals_compared / 10);
    EXPECT_LE(clean_differences, by_cli.vertices.size() / 1000);
    EXPECT_EQ(size_t(scan.views[0].valid_count()) - by_plugin.vertices.size(), size_t(removed[0]));
    // Save Views wrote the cleaned view beside the project; the fused mesh is no view and stays as it is.
    EXPECT_NE(run.log.find("PicoScan saved 2 views in " + directory), std::string::npos) << run.log;
    EXPECT_NE(run.log.find("Fused mesh (Poisson) is not a PicoScan view, left as it is"), std::string::npos) << run.log;
    EXPECT_EQ(size_t(read_view_ply(directory + "/view_0_out.ply").valid_count()), by_plugin.vertices.size());

    // The reopened layers are the unsaved ones: the same points fused, the same relative pose found.
    const std::vector<double> reopened_fused_points = numbers_after(run.log, "PicoScan fused 2 layers (", 1);
    ASSERT_EQ(reopened_fused_points.size(), 1u) << run.log;
    EXPECT_EQ(reopened_fused_points[0], first_fused_points[0]);
    const std::vector<ProjectLayer> reopened = read_project(directory + "/reopened.mlp");
    ASSERT_EQ(reopened.size(), 3u);
    const auto relative = [](const std::vector<ProjectLayer>& layers) {
        return inverse_rigid(nearest_rigid(layers[0].transform)) * nearest_rigid(layers[1].transform);
    };
    const PoseDifference first_error = pose_difference(scan.true_view_to_model[1], relative(saved), scan.centroid(1));
    const PoseDifference error = pose_difference(scan.true_view_to_model[1], relative(reopened), scan.centroid(1));
    const PoseDifference between_sessions = pose_difference(relative(saved), relative(reopened), scan.centroid(1));
    const Mesh first = read_ply(directory + "/fused_first.ply"), second = read_ply(directory + "/fused_reopened.ply");
    const MeshCheck first_check = check_mesh(first), second_check = check_mesh(second);
    const double first_area = mesh_area(first), second_area = mesh_area(second);
    const double first_volume = mesh_volume(first), second_volume = mesh_volume(second);
    std::printf("project saved by meshlabserver -w, layer 0 saved again by the GUI without normals, views deleted, "
                "reopened: cleaning removed %.0f points, %zu kept (the "
                "CLI keeps %zu); %.0f points fused in both sessions; pose error %.4f deg, %.4f mm "
                "(first session %.4f deg, %.4f mm; between the sessions %.4f deg, %.4f mm); fused mesh %s, area %.1f "
                "mm^2, volume %.1f mm^3 (first session: %s, area %.1f mm^2, volume %.1f mm^3)\n",
                removed[0], by_plugin.vertices.size(), by_cli.vertices.size(), reopened_fused_points[0], error.rotation_deg,
                error.translation_mm, first_error.rotation_deg, first_error.translation_mm, between_sessions.rotation_deg,
                between_sessions.translation_mm, second_check.summary().c_str(), second_area, second_volume,
                first_check.summary().c_str(), first_area, first_volume);
    EXPECT_GT(removed[0], 0);
    EXPECT_GT(by_plugin.vertices.size(), 10000u);
    EXPECT_LT(error.rotation_deg, 0.1);
    EXPECT_LT(error.translation_mm, 0.1);
    EXPECT_LT(between_sessions.rotation_deg, 0.01);
    EXPECT_LT(between_sessions.translation_mm, 0.01);
    const EdgeCount edges = count_edges(second);
    EXPECT_GT(second.faces.size(), 5000u);
    EXPECT_EQ(edges.border, 0u);
    EXPECT_EQ(edges.non_manifold, 0u);
    EXPECT_TRUE(first_check.watertight()) << first_check.summary();
    EXPECT_TRUE(second_check.watertight()) << second_check.summary();
    EXPECT_GT(first_volume, 1000.0);
    // Same points, but the first layer's normals recomputed from its grid (after the reconstruction's
    // own clean, so they differ next to the pixels it dropped): most of this two-view surface is
    // closed over by Poisson (about 60 % filled in, not measured), and that guess follows the normals
    // at the scan's borders. Measured: +7 % volume, +4 % area; with the view's own normals in both
    // sessions, 0.1 %.
    EXPECT_NEAR(second_volume, first_volume, 0.1 * first_volume);
    EXPECT_NEAR(second_area, first_area, 0.1 * first_area);

    // Save Views never replaces a file that is not the layer's own: it stops before writing any.
    const std::string again = directory + "/views_again";
    std::filesystem::create_directories(again);
    const std::string someone_else = write_file(again + "/view_0_out.ply", "not mine\n");
    run = run_meshlabserver(directory, std::string(kDeleteCurrentLayer) + save_views(again), "-p project.mlp");
    EXPECT_NE(run.exit_code, 0);
    EXPECT_NE(run.log.find(someone_else + ": exists and is not the file of layer view_0_out.ply"), std::string::npos)
        << run.log;
    std::ifstream kept(someone_else);
    const std::string kept_text((std::istreambuf_iterator<char>(kept)), std::istreambuf_iterator<char>());
    EXPECT_EQ(kept_text, "not mine\n");
    EXPECT_EQ(std::distance(std::filesystem::directory_iterator(again), std::filesystem::directory_iterator()), 1);

    // Built to fool it: a layer's file rewritten as a plain PLY of the same points (no pixels, no
    // camera) and no view of it left. The project is refused, naming the layer and what it lacks;
    // nothing is written.
    write_ply(read_ply(views + "/view_1_out.ply"), views + "/view_1_out.ply");
    run = run_meshlabserver(directory, std::string(kDeleteCurrentLayer) + align(), "-p project.mlp -w never.mlp");
    expect_no_pixel_grid(run, "view_1_out.ply", views, directory + "/never.mlp");
}

// meshlabserver -w PROJECT -x saves every layer over its own file, a PicoScan view PLY included.
// A layer that a PicoScan filter has used carries its pixels and camera in MeshLab's PLY: reopened,
// it cleans as the CLI cleans the view. A layer no PicoScan filter touched is written as a plain
// cloud over its view: reopened, it is refused with the reason, never processed with a guessed
// camera. The overwritten files are no PicoScan views for the CLI either, which says so.
TEST(MeshlabPlugin, ProjectSavedOverItsViewFilesCleansOrIsRefused) {
    const std::string directory = make_temp_dir("meshlab_project_overwritten");
    const std::string views = directory + "/views";
    test_support::two_placement_scan(test_support::PlacementPart::GreyMechanical);  // the shared cached views
    std::filesystem::create_directories(views);
    const std::string cache = std::string(PICOSCAN_TEST_CACHE_DIR) + "/half-v1-grey-mechanical-standing";
    for (int i = 0; i < 2; ++i)
        std::filesystem::copy_file(cache + "/view_" + std::to_string(i) + ".ply", views + "/view_" + std::to_string(i) + ".ply");
    // The CLI cleans the view twice, as the plugin will: once before the save, once after reopening.
    const std::string cli = test_support::cli_path();
    std::string cli_log;
    ASSERT_EQ(run_command(cli + " clean " + views + "/view_0.ply --out " + directory + "/cli_once.ply && " + cli + " clean " +
                              directory + "/cli_once.ply --out " + directory + "/cli_twice.ply",
                          &cli_log),
              0)
        << cli_log;

    // Layer 0 cleaned (a PicoScan filter used it), layer 1 untouched; both saved over their views.
    ServerRun run = run_meshlabserver(directory, make_current(0) + clean(), "-i views/view_0.ply -i views/view_1.ply -w project.mlp -x");
    ASSERT_EQ(run.exit_code, 0) << run.log;
    const std::vector<ProjectLayer> saved = read_project(directory + "/project.mlp");
    ASSERT_EQ(saved.size(), 2u);
    for (int i = 0; i < 2; ++i) EXPECT_EQ(saved[size_t(i)].file, views + "/view_" + std::to_string(i) + ".ply");
    EXPECT_FALSE(std::filesystem::exists(views + "/view_0_out.ply"));
    const std::string used = read_text(views + "/view_0.ply").substr(0, 2000);
    EXPECT_NE(used.find("property float texture_u"), std::string::npos) << used;
    EXPECT_NE(used.find("element camera 1"), std::string::npos) << used;
    const std::string untouched = read_text(views + "/view_1.ply").substr(0, 2000);
    EXPECT_EQ(untouched.find("texture_u"), std::string::npos) << untouched;
    for (int i = 0; i < 2; ++i) {
        const std::string file = views + "/view_" + std::to_string(i) + ".ply";
        cli_log.clear();
        EXPECT_NE(run_command(cli + " clean " + file + " --out " + directory + "/never.ply", &cli_log), 0) << cli_log;
        EXPECT_NE(cli_log.find(file + ": has no camera pixel grid"), std::string::npos) << cli_log;
    }
    EXPECT_FALSE(std::filesystem::exists(directory + "/never.ply"));

    // Reopened: the used layer's own (overwritten) file holds its pixels and camera.
    run = run_meshlabserver(directory, make_current(0) + clean(), "-p project.mlp -o cleaned.ply -l 0");
    ASSERT_EQ(run.exit_code, 0) << run.log;
    EXPECT_EQ(run.log.find("taken from the view file"), std::string::npos) << run.log;
    const Mesh by_plugin = read_ply(directory + "/cleaned.ply"), by_cli = read_ply(directory + "/cli_twice.ply");
    const std::vector<double> removed = numbers_after(run.log, "removed", 1);
    ASSERT_EQ(removed.size(), 1u) << run.log;
    std::printf("project saved over its views (-x), reopened: the second clean removed %.0f and kept %zu points, the "
                "CLI's second clean of the view %zu, max distance %.2g mm\n",
                removed[0], by_plugin.vertices.size(), by_cli.vertices.size(), max_distance(by_plugin.vertices, by_cli.vertices));
    ASSERT_EQ(by_plugin.vertices.size(), by_cli.vertices.size());
    EXPECT_LT(max_distance(by_plugin.vertices, by_cli.vertices), 1e-4);

    // The untouched layer: MeshLab read neither its pixels nor its camera from the view, so it wrote a
    // plain cloud over it. Refused on reopening, nothing written.
    run = run_meshlabserver(directory, make_current(1) + clean(), "-p project.mlp -o never.ply -l 1");
    expect_no_pixel_grid(run, "view_1.ply", views, directory + "/never.ply");
}

namespace {

// A project of the views of two placements, as the register and CLI suites simulated them
// (shared cache): the first placement's 8 views of `first`, then the second placement's of
// `second`, linked into `directory`. Returns the layer labels (file names) in order.
std::vector<std::string> two_placement_project(const std::string& directory, test_support::PlacementPart first,
                                               test_support::PlacementPart second) {
    const test_support::TurntableScan& standing = test_support::two_placement_scan(first);
    test_support::two_placement_scan(second);  // makes its cached views if they are not there yet
    const std::string cache = PICOSCAN_TEST_CACHE_DIR;
    std::vector<std::string> files;
    for (size_t i = 0; i < 2 * test_support::kViewsPerPlacement; ++i) {
        const bool side = i >= test_support::kViewsPerPlacement;
        const std::string folder = "half-v1-" + test_support::placement_part_name(side ? second : first) +
                                   (side ? "-on-its-side" : "-standing");
        const std::string view = "view_" + std::to_string(i % test_support::kViewsPerPlacement) + ".ply";
        files.push_back((side ? "side_" : "standing_") + view);
        std::filesystem::create_symlink(cache + "/" + folder + "/" + view, directory + "/" + files.back());
    }
    EXPECT_EQ(standing.views.size(), files.size());
    write_project(directory + "/project.mlp", files);
    return files;
}

}  // namespace

// The plain grey part in two placements (standing, then on its side), 8 turntable layers each,
// no paint and no axis given: Align Layers with "8 8" in mode Automatic (the default) puts every
// layer on its true pose. Features alone cannot place a plain part's layers; the log says which
// way placed each layer.
TEST(MeshlabPlugin, AlignTwoPlacementsOfAPlainPart) {
    const std::string directory = make_temp_dir("meshlab_placements");
    const auto part = test_support::PlacementPart::GreyMechanical;
    const std::vector<std::string> files = two_placement_project(directory, part, part);
    const ServerRun run = run_meshlabserver(directory, align({{"placements", "8 8"}}), "-p project.mlp -w aligned.mlp");
    ASSERT_EQ(run.exit_code, 0) << run.log;
    EXPECT_NE(run.log.find("PicoScan aligned 16 layers"), std::string::npos) << run.log;
    // Each way tried, and every layer's method: features where they aligned the whole placement,
    // else the turntable round, which must then be kept for at least one placement.
    for (size_t at = run.log.find("PicoScan placement "); at != std::string::npos; at = run.log.find("PicoScan placement ", at + 1))
        std::printf("%s\n", run.log.substr(at, run.log.find('\n', at) - at).c_str());
    EXPECT_NE(run.log.find("PicoScan placement 1 by features: "), std::string::npos) << run.log;
    EXPECT_NE(run.log.find("by turntable round (axis estimated): 8 of 8 layers aligned; kept"), std::string::npos) << run.log;
    for (int placement = 1; placement <= 2; ++placement) {
        const bool by_features =
            run.log.find("PicoScan placement " + std::to_string(placement) + " by features: 8 of 8 layers aligned; kept") !=
            std::string::npos;
        const std::string method = by_features ? "features" : "turntable round (axis estimated)";
        for (size_t i = (placement - 1) * 8; i < size_t(placement) * 8; ++i)
            EXPECT_NE(run.log.find("PicoScan aligned " + files[i] + " by " + method + ": residual "), std::string::npos)
                << files[i] << "\n" << run.log;
    }
    const std::vector<double> placement = numbers_after(run.log, "placement 2 aligned to the others: residual", 1);
    ASSERT_EQ(placement.size(), 1u) << run.log;
    const std::vector<ProjectLayer> layers = read_project(directory + "/aligned.mlp");
    ASSERT_EQ(layers.size(), files.size());
    const test_support::TurntableScan& scan = test_support::two_placement_scan(part);
    double worst_rotation = 0, worst_translation = 0;
    for (size_t i = 0; i < layers.size(); ++i) {
        const PoseDifference error =
            pose_difference(scan.true_view_to_model[i], nearest_rigid(layers[i].transform), scan.centroid(i));
        worst_rotation = std::max(worst_rotation, error.rotation_deg);
        worst_translation = std::max(worst_translation, error.translation_mm);
    }
    std::printf("two placements in MeshLab: placement 2 joined with residual %.4f mm; worst pose error of 16 layers "
                "%.4f deg, %.4f mm\n", placement[0], worst_rotation, worst_translation);
    EXPECT_LT(placement[0], 0.1);
    EXPECT_LT(worst_rotation, 0.05);
    EXPECT_LT(worst_translation, 0.05);
}

// A known turntable axis (as 'picoscan stitch' prints it, here the truth's) for the plain grey
// part's standing round: every layer on its true pose. The same axis laid across the part (turned
// 90 degrees about the camera's line of sight) is refused and no transform is changed.
TEST(MeshlabPlugin, AlignPlainRoundWithAKnownAxisAndRefusesAWrongOne) {
    const std::string directory = make_temp_dir("meshlab_known_axis");
    const auto part = test_support::PlacementPart::GreyMechanical;
    std::vector<std::string> files = two_placement_project(directory, part, part);
    files.resize(test_support::kViewsPerPlacement);  // the standing round only
    write_project(directory + "/project.mlp", files);
    const test_support::TurntableScan& scan = test_support::two_placement_scan(part);
    const std::vector<cv::Matx44d> truth(scan.true_view_to_model.begin(),
                                         scan.true_view_to_model.begin() + test_support::kViewsPerPlacement);
    const TurntableAxis axis = fit_turntable_axis(truth);
    auto axis_parameters = [](const cv::Vec3d& point, const cv::Vec3d& direction) {
        auto text = [](const cv::Vec3d& v) { return std::to_string(v[0]) + " " + std::to_string(v[1]) + " " + std::to_string(v[2]); };
        return align({{"mode", "3"}, {"turntableAxisPoint", text(point)}, {"turntableAxisDirection", text(direction)}});
    };
    ServerRun run = run_meshlabserver(directory, axis_parameters(axis.point_mm, axis.direction), "-p project.mlp -w aligned.mlp");
    ASSERT_EQ(run.exit_code, 0) << run.log;
    EXPECT_NE(run.log.find("placement 1 by turntable axis (given): 8 of 8 layers aligned"), std::string::npos) << run.log;
    const std::vector<ProjectLayer> layers = read_project(directory + "/aligned.mlp");
    ASSERT_EQ(layers.size(), files.size());
    double worst_rotation = 0, worst_translation = 0;
    for (size_t i = 0; i < layers.size(); ++i) {
        const PoseDifference error = pose_difference(truth[i], nearest_rigid(layers[i].transform), scan.centroid(i));
        worst_rotation = std::max(worst_rotation, error.rotation_deg);
        worst_translation = std::max(worst_translation, error.translation_mm);
    }
    std::printf("known turntable axis in MeshLab: worst pose error of 8 layers %.4f deg, %.4f mm\n", worst_rotation,
                worst_translation);
    EXPECT_LT(worst_rotation, 0.05);
    EXPECT_LT(worst_translation, 0.05);

    const cv::Vec3d across(-axis.direction[1], axis.direction[0], 0);  // square to the axis and the line of sight
    run = run_meshlabserver(directory, axis_parameters(axis.point_mm, cv::normalize(across)), "-p project.mlp -w never.mlp");
    EXPECT_NE(run.exit_code, 0);
    const size_t refused = run.log.find("layers could not be aligned, no transform changed");
    ASSERT_NE(refused, std::string::npos) << run.log;
    EXPECT_NE(run.log.find("no turntable step fits the views"), std::string::npos) << run.log;
    std::printf("wrong axis in MeshLab: %s\n", run.log.substr(refused, run.log.find('\n', refused) - refused).c_str());
    EXPECT_FALSE(std::filesystem::exists(directory + "/never.mlp"));
}

// Built to fool it: the second placement is another part (the stepped block on its side). Align
// names the placement with the reason and changes no transform. A count that does not match
// the layers is refused naming the parameter.
TEST(MeshlabPlugin, AlignRefusesAPlacementOfAnotherPart) {
    const std::string directory = make_temp_dir("meshlab_placement_other_part");
    two_placement_project(directory, test_support::PlacementPart::GreyMechanical, test_support::PlacementPart::SteppedBlock);
    ServerRun run = run_meshlabserver(directory, align({{"placements", "8 9"}, {"mode", "2"}}),
                                      "-p project.mlp -w never.mlp");
    EXPECT_NE(run.exit_code, 0);
    EXPECT_NE(run.log.find("placements: gives 17 layers in all, but 16 PicoScan layers are visible"), std::string::npos)
        << run.log;
    run = run_meshlabserver(directory, align({{"placements", "8 8"}, {"mode", "2"}}),
                            "-p project.mlp -w never.mlp");
    EXPECT_NE(run.exit_code, 0);
    const size_t refused = run.log.find("placement 2 NOT aligned: ");
    ASSERT_NE(refused, std::string::npos) << run.log;
    std::printf("another part as placement 2: %s\n", run.log.substr(refused, run.log.find('\n', refused) - refused).c_str());
    EXPECT_NE(run.log.find("8 of 16 layers could not be aligned, no transform changed"), std::string::npos) << run.log;
    EXPECT_EQ(run.log.find("PicoScan aligned 16 layers"), std::string::npos) << run.log;
}

namespace {

// The vertex quality of an ASCII PLY (meshlabserver -m vq sa).
std::vector<float> ascii_ply_quality(const std::string& path) {
    std::ifstream in(path);
    std::string line;
    size_t vertices = 0;
    int property = 0, quality = -1;
    bool in_vertex = false;
    while (std::getline(in, line) && line.rfind("end_header", 0) != 0) {
        std::istringstream words(line);
        std::string word, type, name;
        words >> word;
        if (word == "element") {
            words >> name;
            in_vertex = name == "vertex";
            if (in_vertex) words >> vertices;
        } else if (word == "property" && in_vertex) {
            words >> type >> name;
            if (name == "quality") quality = property;
            ++property;
        }
    }
    std::vector<float> values;
    if (quality < 0) return values;
    for (size_t v = 0; v < vertices && std::getline(in, line); ++v) {
        std::istringstream fields(line);
        float value = 0;
        for (int k = 0; k <= quality; ++k) fields >> value;
        values.push_back(value);
    }
    return values;
}

}  // namespace

// Fuse and Mesh's fill on one placement (the plain grey part standing on the turntable, its 8
// layers on their true poses; the bottom never seen). Open leaves the bottom open and invents
// nothing; Table closes it with a flat cap at the table: watertight, the part's volume. The saved
// vertex quality says which vertices were filled in (0) and which measured (1).
TEST(MeshlabPlugin, FuseFillOpenLeavesTheUnseenSideOpenAndTableClosesIt) {
    const std::string directory = make_temp_dir("meshlab_fuse_fill");
    const auto part = test_support::PlacementPart::GreyMechanical;
    std::vector<std::string> files = two_placement_project(directory, part, part);
    files.resize(test_support::kViewsPerPlacement);  // the standing round only
    const test_support::TurntableScan& scan = test_support::two_placement_scan(part);
    write_project(directory + "/project.mlp", files, scan.true_view_to_model);
    double true_volume = 0;  // of the part's triangles (divergence theorem)
    for (const cv::Vec3i& f : scan.part.faces)
        true_volume += cv::Vec3d(scan.part.vertices[f[0]]).dot(cv::Vec3d(scan.part.vertices[f[1]]).cross(cv::Vec3d(scan.part.vertices[f[2]]))) / 6;
    const cv::Matx44d model_to_part = inverse_rigid(scan.part_to_camera[0]);
    const std::string fused_layer = std::to_string(files.size());
    for (const std::string fill : {"Open", "Table"}) {
        const std::string out = "fused_" + fill + ".ply";
        const auto start = std::chrono::steady_clock::now();
        const ServerRun run = run_meshlabserver(directory, fuse({{"fill", fill == "Open" ? "2" : "1"}, {"sampleSpacing", "1"}}),
                                                "-p project.mlp -o " + out + " -l " + fused_layer + " -m vq sa");
        ASSERT_EQ(run.exit_code, 0) << run.log;
        const size_t report = run.log.find("PicoScan fused");
        ASSERT_NE(report, std::string::npos) << run.log;
        const std::string line = run.log.substr(report, run.log.find('\n', report) - report);
        // The layers are handed to the core one at a time; every valid point of every view is fused.
        size_t view_points = 0;
        for (const std::string& file : files) view_points += size_t(read_view_ply(directory + "/" + file).valid_count());
        const std::vector<double> fused_points = numbers_after(line, "layers (", 1);
        ASSERT_EQ(fused_points.size(), 1u) << line;
        EXPECT_EQ(size_t(fused_points[0]), view_points) << line;
        const Mesh fused = read_ply(directory + "/" + out);
        const std::vector<float> quality = ascii_ply_quality(directory + "/" + out);
        ASSERT_EQ(quality.size(), fused.vertices.size()) << out;
        const EdgeCount edges = count_edges(fused);
        std::vector<double> filled_heights;  // height above the table (part frame z) of the filled-in vertices
        for (size_t v = 0; v < fused.vertices.size(); ++v) {
            EXPECT_TRUE(quality[v] == 0 || quality[v] == 1) << quality[v];
            if (quality[v] != 0) continue;
            const cv::Vec4d p = model_to_part * cv::Vec4d(fused.vertices[v][0], fused.vertices[v][1], fused.vertices[v][2], 1);
            filled_heights.push_back(p[2]);
        }
        std::sort(filled_heights.begin(), filled_heights.end());
        const MeshCheck check = check_mesh(fused);
        std::printf("fill %s (meshlabserver %.1f s): %s\n  %zu border edges, %zu of %zu vertices filled in", fill.c_str(),
                    std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), line.c_str(), edges.border,
                    filled_heights.size(), fused.vertices.size());
        if (!filled_heights.empty())
            std::printf(", their height above the table %.3f..%.3f mm (median %.3f)", filled_heights.front(),
                        filled_heights.back(), filled_heights[filled_heights.size() / 2]);
        if (fill == "Table")
            std::printf("; as saved: %s; volume %.1f mm^3 (true part %.1f mm^3, %+.2f %%)", check.summary().c_str(),
                        check.volume_mm3, true_volume, 100 * (check.volume_mm3 / true_volume - 1));
        std::printf("\n");
        if (fill == "Open") {
            EXPECT_NE(line.find("NOT watertight"), std::string::npos) << line;
            EXPECT_NE(line.find("; 0.0 % of the surface filled in"), std::string::npos) << line;
            EXPECT_GT(edges.border, 100u);
            // The contoured points are measured; a vertex flagged filled is a rare exception (1 in 51 781).
            EXPECT_LT(filled_heights.size(), fused.vertices.size() / 1000);
        } else {
            EXPECT_NE(line.find("; watertight;"), std::string::npos) << line;
            EXPECT_EQ(edges.border, 0u);
            EXPECT_EQ(edges.non_manifold, 0u);
            EXPECT_EQ(line.find("; 0.0 % of the surface filled in"), std::string::npos) << line;
            ASSERT_GT(filled_heights.size(), 100u);
            // The cap lies on the table (z = 0): nothing bulges below it (the filled walls of the
            // through hole rise above it), and the closed mesh holds the part's volume.
            EXPECT_GT(filled_heights.front(), -0.3);
            EXPECT_NEAR(check.volume_mm3, true_volume, 0.01 * true_volume);
        }
    }
}

namespace {

// The seed stereo rig at half resolution (two 800 x 600 cameras 200 mm apart, the projector
// between them) looking at a sphere of radius 25 mm: camera1/, camera2/ and stereo.yml, plus a
// camera-projector calibration of the first camera. Made once for the suite.
const cv::Vec3d kStereoSphereCentre{0, 0, 400};
const double kStereoSphereRadius = 25;

Calibration half_resolution(Calibration calibration) {
    calibration.camera_size = {calibration.camera_size.width / 2, calibration.camera_size.height / 2};
    calibration.camera_matrix(0, 0) /= 2, calibration.camera_matrix(1, 1) /= 2;
    // Pixel centres at integer coordinates: scaled about the corner of the first pixel.
    calibration.camera_matrix(0, 2) = (calibration.camera_matrix(0, 2) + 0.5) / 2 - 0.5;
    calibration.camera_matrix(1, 2) = (calibration.camera_matrix(1, 2) + 0.5) / 2 - 0.5;
    return calibration;
}

const std::string& stereo_sphere_folder() {
    static const std::string folder = [] {
        const std::string root = make_temp_dir("meshlab_stereo");
        SeedStereoRig rig = seed_stereo_rig();
        rig.left = half_resolution(rig.left);
        rig.right = half_resolution(rig.right);
        rig.stereo = stereo_from_projector_calibrations(rig.left, rig.right);
        PatternOptions patterns;
        patterns.shifts = 8;
        Scene scene;
        scene.spheres.push_back({kStereoSphereCentre, kStereoSphereRadius, 0.9});
        const auto captures = simulate_stereo_capture(make_pattern_sequence(patterns), rig, scene);
        write_capture_set(captures.first, root + "/camera1");
        write_capture_set(captures.second, root + "/camera2");
        write_stereo_calibration(rig.stereo, root + "/stereo.yml");
        write_calibration(rig.left, root + "/camera_projector.yml");
        write_stereo_calibration(seed_stereo_rig().stereo, root + "/full_size.yml");  // 1600 x 1200 cameras
        return root;
    }();
    return folder;
}

}  // namespace

// A stereo calibration and two capture folders: the filter takes the binocular path, its layer is
// the core recipe's view point for point, and the sphere is the scene's.
TEST(MeshlabPlugin, StereoReconstructMeasuresTheSphere) {
    const std::string& root = stereo_sphere_folder();
    const std::map<std::string, std::string> stereo{{"captureFolder", root + "/camera1"},
                                                    {"calibrationFile", root + "/stereo.yml"},
                                                    {"secondCaptureFolder", root + "/camera2"}};
    // A second layer of the same scan is cleaned: a stereo layer carries its pixel grid and camera.
    const ServerRun run = run_meshlabserver(root, reconstruct(stereo) + measure("sphere") + reconstruct(stereo) + clean(),
                                            "-o stereo.ply -l 0 -m vc vn vq -o cleaned.ply -l 1");
    ASSERT_EQ(run.exit_code, 0) << run.log;
    EXPECT_NE(run.log.find("(stereo):"), std::string::npos) << run.log;
    EXPECT_NE(run.log.find("left-right consistency"), std::string::npos) << run.log;
    const Mesh layer = read_ply(root + "/stereo.ply");
    const StereoReconstructResult core = reconstruct_stereo_view(root + "/camera1", root + "/camera2",
                                                                 read_stereo_calibration(root + "/stereo.yml"), "stereo.yml");
    const PointCloud expected = to_point_cloud(core.view);
    ASSERT_EQ(layer.vertices.size(), expected.points.size());
    EXPECT_LT(max_distance(layer.vertices, expected.points), 1e-4);
    const SphereFit fit = fit_sphere(layer.vertices);
    std::printf("stereo sphere through MeshLab (800x600 cameras): %zu points; radius %.4f mm (truth %.1f), centre error "
                "%.4f mm, RMS %.4f mm\n",
                layer.vertices.size(), fit.radius_mm, kStereoSphereRadius, cv::norm(fit.centre - kStereoSphereCentre),
                fit.rms_mm);
    EXPECT_GT(layer.vertices.size(), 15000u);
    EXPECT_LT(std::abs(fit.radius_mm - kStereoSphereRadius), 0.015);
    EXPECT_LT(cv::norm(fit.centre - kStereoSphereCentre), 0.02);
    EXPECT_LT(fit.rms_mm, 0.02);
    const std::vector<double> logged_radius = numbers_after(run.log, "radius", 1);
    ASSERT_EQ(logged_radius.size(), 1u) << run.log;
    EXPECT_NEAR(logged_radius[0], fit.radius_mm, 1e-3);
    const std::vector<double> removed = numbers_after(run.log, "removed", 1);
    ASSERT_EQ(removed.size(), 1u) << run.log;
    std::printf("stereo layer cleaned: %.0f of %zu points removed\n", removed[0], layer.vertices.size());
    EXPECT_EQ(read_ply(root + "/cleaned.ply").vertices.size() + size_t(removed[0]), layer.vertices.size());
    EXPECT_LT(removed[0], 0.05 * layer.vertices.size());
}

// Each wrong combination is refused with a message naming the parameter or the reason, and no
// layer is saved.
TEST(MeshlabPlugin, StereoReconstructRefusesWrongCombinations) {
    const std::string& root = stereo_sphere_folder();
    const std::string first = root + "/camera1", second = root + "/camera2";
    const std::vector<std::pair<std::map<std::string, std::string>, std::string>> cases{
        {{{"captureFolder", first}, {"calibrationFile", root + "/stereo.yml"}},
         "error: secondCaptureFolder: is required: " + root + "/stereo.yml is a stereo calibration (two cameras)"},
        {{{"captureFolder", first}, {"calibrationFile", root + "/camera_projector.yml"}, {"secondCaptureFolder", second}},
         "error: secondCaptureFolder: " + root + "/camera_projector.yml is a camera-projector calibration"},
        {{{"captureFolder", first}, {"calibrationFile", root + "/stereo.yml"}, {"secondCaptureFolder", root + "/none"}},
         "error: " + root + "/none: second capture folder not found"},
        {{{"captureFolder", first}, {"calibrationFile", root + "/stereo.yml"}, {"secondCaptureFolder", second},
          {"sequence", "1"}},
         "error: sequence: the presets take the projector's size from a camera-projector calibration"},
        {{{"captureFolder", first}, {"calibrationFile", root + "/full_size.yml"}, {"secondCaptureFolder", second}},
         "error: " + root + "/full_size.yml: camera1_size is 1600x1200 but the captures in " + first + " are 800x600"},
        // The cameras swapped: both decode, but the projector rows show that R, T do not fit.
        {{{"captureFolder", second}, {"calibrationFile", root + "/stereo.yml"}, {"secondCaptureFolder", first}},
         "does not fit these captures"},
    };
    for (const auto& [overrides, message] : cases) {
        const ServerRun run = run_meshlabserver(root, reconstruct(overrides), "-o never.ply");
        EXPECT_NE(run.exit_code, 0) << message;
        EXPECT_NE(run.log.find(message), std::string::npos) << run.log;
    }
    EXPECT_FALSE(std::ifstream(root + "/never.ply").good());
}

// The exact demo part as part.ply and its scan as scan.ply (points over its surface with 20 um of
// noise); returns the scan.
PointCloud write_part_and_its_scan(const std::string& directory) {
    const Mesh part = mechanical_part();
    write_ply(part, directory + "/part.ply");
    PointCloud scan;
    scan.points = test_support::noisy_surface_points(part.vertices, part.faces, 10, 0.02, 5);
    write_ply(scan, directory + "/scan.ply");
    return scan;
}

// A flattened mesh (the exact demo part: its cut has no noise) and the scan it stands for (points
// over its surface with 20 um of noise, a point cloud layer): with the scan layer chosen, the
// section's tolerance is 5 x the noise read on the scan's points; with the mesh itself chosen (no
// scan) it falls to the cut's 0.005 mm floor and the log says to set it. A scan layer with a
// tolerance, or a plane off the mesh, is refused naming the parameter.
TEST(MeshlabPlugin, SectionToleranceComesFromTheScanLayer) {
    const std::string directory = make_temp_dir("meshlab_section");
    write_part_and_its_scan(directory);
    const std::string dxf = directory + "/outline.dxf";
    const ServerRun run = run_meshlabserver(
        directory,
        make_current(0) + section({{"at", "12"}, {"scanLayer", "1"}}) + section({{"at", "12"}, {"dxfFile", dxf}}),
        "-i part.ply -i scan.ply");
    ASSERT_EQ(run.exit_code, 0) << run.log;
    const std::string from_scan = "PicoScan section of part.ply: the scan layer scan.ply: tolerance ";
    const size_t at = run.log.find(from_scan);
    ASSERT_NE(at, std::string::npos) << run.log;
    std::istringstream line(run.log.substr(at + from_scan.size()));
    double tolerance = 0, noise = 0;
    std::string words;
    ASSERT_TRUE(line >> tolerance) << run.log;
    std::getline(line, words, ',');  // " mm: 5 x the noise of the scan the mesh was made from"
    EXPECT_EQ(words, " mm: 5 x the noise of the scan the mesh was made from");
    ASSERT_TRUE(line >> noise) << run.log;
    std::printf("scan layer noise %.4f mm (20 um put in), tolerance %.4f mm\n", noise, tolerance);
    EXPECT_NEAR(noise, 0.02, 0.004);
    EXPECT_NEAR(tolerance, 5 * noise, 0.0002);

    const std::vector<double> from_cut = numbers_after(run.log, "no scan layer (the current layer was chosen): tolerance", 1);
    ASSERT_EQ(from_cut.size(), 1u) << run.log;
    EXPECT_EQ(from_cut[0], 0.005);  // the cut of a flattened mesh has no noise: the floor
    EXPECT_NE(run.log.find("no scan given: set it yourself"), std::string::npos) << run.log;
    EXPECT_NE(test_support::read_file_bytes(dxf).find("LINE"), std::string::npos);

    const auto refused = [&](const std::map<std::string, std::string>& overrides, const std::string& message) {
        const ServerRun bad = run_meshlabserver(directory, make_current(0) + section(overrides), "-i part.ply -i scan.ply");
        EXPECT_NE(bad.log.find("PicoScan: Fit Cross-section error: " + message), std::string::npos) << bad.log;
    };
    refused({{"at", "12"}, {"scanLayer", "1"}, {"tolerance", "0.05"}}, "scanLayer: sets the default tolerance");
    refused({{"at", "500"}}, "at: ");
}

// The DXF's name is checked before the cut: the mesh's own file (no .dxf) is refused and stays as it
// was, and a folder that does not exist is named, not made; neither run cuts or writes anything.
TEST(MeshlabPlugin, SectionChecksItsDxfBeforeTheCut) {
    const std::string directory = make_temp_dir("meshlab_section_dxf");
    write_part_and_its_scan(directory);
    const std::string part = directory + "/part.ply", part_bytes = test_support::read_file_bytes(part);
    for (const auto& [dxf, message] :
         {std::pair{part, "dxfFile: '" + part + "' must end in .dxf"},
          std::pair{directory + "/missing/outline.dxf", "dxfFile: the folder '" + directory + "/missing' does not exist"}}) {
        const ServerRun run =
            run_meshlabserver(directory, make_current(0) + section({{"at", "12"}, {"dxfFile", dxf}}), "-i part.ply");
        EXPECT_NE(run.exit_code, 0) << run.log;
        EXPECT_NE(run.log.find("PicoScan: Fit Cross-section error: " + message), std::string::npos) << run.log;
        EXPECT_EQ(run.log.find("PicoScan section of part.ply"), std::string::npos) << run.log;
    }
    EXPECT_TRUE(test_support::read_file_bytes(part) == part_bytes) << "the layer's own file was written over";
    EXPECT_FALSE(std::filesystem::exists(directory + "/missing"));
}

// The scan layer is the user's pick among all point layers: one that is not the mesh's scan (the
// right scan moved 10 mm, or another part's scan) is refused with one line naming the layer, before its
// noise could set the tolerance; the right one (layer 1) still sets it.
TEST(MeshlabPlugin, SectionRefusesAScanLayerThatIsNotTheMeshs) {
    const std::string directory = make_temp_dir("meshlab_section_scan");
    const PointCloud scan = write_part_and_its_scan(directory);
    PointCloud shifted = scan;  // along the block's length: its top, bottom, front and back still touch the mesh
    for (cv::Vec3f& p : shifted.points) p[0] += 10;
    write_ply(shifted, directory + "/shifted.ply");
    MechanicalPartShape narrow;  // another part: a narrower, taller block with a smaller hole and boss
    narrow.length_mm = 30, narrow.width_mm = 20, narrow.height_mm = 40, narrow.chamfer_mm = 4;
    narrow.hole_centre_mm = {-6, 0}, narrow.hole_diameter_mm = 5, narrow.boss_centre_mm = {7, -1}, narrow.boss_diameter_mm = 6;
    const Mesh other_part = mechanical_part(narrow);
    PointCloud other;
    other.points = test_support::noisy_surface_points(other_part.vertices, other_part.faces, 10, 0.02, 6);
    write_ply(other, directory + "/other_part_scan.ply");
    const std::string inputs = "-i part.ply -i scan.ply -i shifted.ply -i other_part_scan.ply";
    for (const auto& [layer, name] : {std::pair{"2", "shifted.ply"}, std::pair{"3", "other_part_scan.ply"}}) {
        const ServerRun run = run_meshlabserver(directory, make_current(0) + section({{"at", "12"}, {"scanLayer", layer}}), inputs);
        const std::string message = std::string("PicoScan: Fit Cross-section error: scanLayer: ") + name +
                                    ": is not the scan this mesh was made from: ";
        const size_t at = run.log.find(message);
        ASSERT_NE(at, std::string::npos) << run.log;
        std::istringstream line(run.log.substr(at + message.size()));
        double share = 0;
        ASSERT_TRUE(line >> share) << run.log;
        const std::vector<double> off = numbers_after(run.log.substr(at), "half lie more than", 1);
        ASSERT_EQ(off.size(), 1u) << run.log;
        std::printf("%s: %.0f %% of its points near the mesh, median distance %.4f mm\n", name, share, off[0]);
        EXPECT_LT(share, 80);
        EXPECT_EQ(run.log.find("PicoScan section of part.ply"), std::string::npos) << run.log;
    }
    const ServerRun right = run_meshlabserver(directory, make_current(0) + section({{"at", "12"}, {"scanLayer", "1"}}), inputs);
    ASSERT_EQ(right.exit_code, 0) << right.log;
    EXPECT_NE(right.log.find("PicoScan section of part.ply: the scan layer scan.ply: tolerance "), std::string::npos) << right.log;
}

