#include "filter_picoscan.h"

#include "scan_layer.h"

#include "picoscan/calibration.h"
#include "picoscan/capture_set.h"
#include "picoscan/error.h"
#include "picoscan/file_output.h"
#include "picoscan/fit.h"
#include "picoscan/io.h"
#include "picoscan/pipeline.h"
#include "picoscan/section_fit.h"
#include "picoscan/simulate.h"

#include <QDir>
#include <QFileInfo>
#include <QRegularExpression>
#include <QTemporaryDir>

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>

using namespace picoscan;
using namespace picoscan_meshlab;

namespace {

// Parameter names, shared by initParameterSet, applyFilter and the .mlx scripts.
const char* const kCaptureFolder = "captureFolder";
const char* const kCalibrationFile = "calibrationFile";
const char* const kSecondCaptureFolder = "secondCaptureFolder";
const char* const kSequence = "sequence";
const char* const kManifestFile = "manifestFile";
const char* const kShifts = "shifts";
const char* const kPeriods = "periods";
const char* const kGrayBits = "grayBits";
const char* const kBinaryOnly = "binaryOnly";
const char* const kMinContrast = "minContrast";
const char* const kMinModulation = "minModulation";
const char* const kOutput = "output";
const char* const kMeshStep = "meshStep";
const char* const kSceneFile = "sceneFile";
const char* const kPeriodBits = "periodBits";
const char* const kNoise = "noise";
const char* const kFullScale = "fullScale";
const char* const kBlur = "blur";
const char* const kSeed = "seed";
const char* const kSaveCaptures = "saveCaptureFolder";
const char* const kPartView = "partView";
const char* const kMinQuality = "minQuality";
const char* const kMaxGrazing = "maxGrazingDeg";
const char* const kWindow = "windowPx";
const char* const kOutlierSigma = "outlierSigma";
const char* const kRadiusFootprints = "radiusFootprints";
const char* const kMinNeighbours = "minNeighbours";
const char* const kMinCluster = "minClusterPoints";
const char* const kOrbFeatures = "orbFeatures";
const char* const kIcpMaxDistance = "icpMaxDistance";
const char* const kAlignSpacing = "sampleSpacing";
const char* const kMinOverlap = "minOverlap";
const char* const kPlacements = "placements";
const char* const kAlignMode = "mode";
const char* const kTurntableAxisPoint = "turntableAxisPoint";
const char* const kTurntableAxisDirection = "turntableAxisDirection";
const char* const kTurntableStep = "turntableStepDeg";
const char* const kMethod = "method";
const char* const kFill = "fill";
const char* const kMeshSpacing = "sampleSpacing";
const char* const kPoissonTriangleSize = "poissonTriangleSize";
const char* const kPoissonDistance = "poissonDistance";
const char* const kFrontMaxRadius = "frontMaxRadius";
const char* const kMaxHole = "maxHoleDiameter";
const char* const kTargetFaces = "targetFaces";
const char* const kShape = "shape";
const char* const kSelectedOnly = "selectedOnly";
const char* const kModelFrame = "modelFrame";
const char* const kViewFolder = "viewFolder";
const char* const kSectionAxis = "axis";
const char* const kSectionAt = "at";
const char* const kSectionBand = "band";
const char* const kSectionTolerance = "tolerance";
const char* const kScanLayer = "scanLayer";
const char* const kSectionDxf = "dxfFile";

// Values of the "sequence" enum: where the frame order of a capture set comes from.
enum SequenceSource { OwnManifest, SlmasterCgc, SlstudioGray };
enum OutputKind { PointCloudLayer, GridMeshLayer };
enum FitShape { SphereShape, PlaneShape };
enum MeshingMethod { PoissonMethod, AdvancingFrontMethod };
enum SectionAxis { SectionX, SectionY, SectionZ };
// Align Layers' mode: how each placement's layers are aligned (the core's stitch_views recipe).
enum AlignMode { AutomaticAlign, FeaturesAlign, TurntableRoundAlign, TurntableAxisAlign };
// Fuse and Mesh's fill, in the order of the FreeCAD workbench's ScanMesh Fill.
const QStringList kFillNames{"Poisson", "Table", "Open"};
const MeshFill kFills[] = {MeshFill::Poisson, MeshFill::Table, MeshFill::Open};

std::string parameter_text(const QString& value) { return value.trimmed().toStdString(); }

// An enum parameter's value: a script (meshlabserver's .mlx) can give any number, and one out of
// range must not quietly run one of the choices.
int enum_choice(const RichParameterList& parameters, const char* name, int count) {
    const int value = parameters.getEnum(name);
    if (value < 0 || value >= count)
        throw Error(name, "must be 0.." + std::to_string(count - 1) + ", is " + std::to_string(value));
    return value;
}

// Reports core progress through MeshLab's callback, only when the percentage or stage changes.
ProgressCallback meshlab_progress(vcg::CallBackPos* callback) {
    if (callback == nullptr) return nullptr;
    auto last = std::make_shared<std::pair<int, std::string>>(-1, "");
    return [callback, last](double fraction, const std::string& stage) {
        // Steps of 5 %: meshlabserver prints every call.
        const int percent = 5 * std::max(0, std::min(20, int(fraction * 20)));
        if (percent == last->first && stage == last->second) return true;
        *last = {percent, stage};
        return callback(percent, ("PicoScan " + stage).c_str());
    };
}

// The core's errors name option fields ("decode.min_modulation"); the user set parameters.
QString parameter_for_field(const std::string& field) {
    static const std::map<std::string, const char*> parameters{
        {"patterns.shifts", kShifts},
        {"patterns.period_bits", kPeriodBits},
        {"decode.min_contrast", kMinContrast},
        {"decode.min_modulation", kMinModulation},
        {"camera.full_scale_dn", kFullScale},
        {"camera.noise_sigma_dn", kNoise},
        {"camera.blur_sigma_px", kBlur},
        {"cleaning.min_quality", kMinQuality},
        {"cleaning.max_grazing_deg", kMaxGrazing},
        {"cleaning.window_px", kWindow},
        {"cleaning.outlier_sigma", kOutlierSigma},
        {"cleaning.radius_footprints", kRadiusFootprints},
        {"cleaning.min_neighbours", kMinNeighbours},
        {"cleaning.min_cluster_points", kMinCluster},
        {"registration.orb_features", kOrbFeatures},
        {"registration.icp_max_distance_mm", kIcpMaxDistance},
        {"registration.sample_spacing_mm", kAlignSpacing},
        {"registration.min_overlap", kMinOverlap},
        {"placement_of_view", kPlacements},
        {"registration.turntable_round", kAlignMode},
        {"automatic", kAlignMode},
        {"turntable.point_mm", kTurntableAxisPoint},
        {"turntable.direction", kTurntableAxisDirection},
        {"turntable.step_deg", kTurntableStep},
        {"mesh.sample_spacing_mm", kMeshSpacing},
        {"mesh.poisson_triangle_size", kPoissonTriangleSize},
        {"mesh.poisson_distance", kPoissonDistance},
        {"mesh.advancing_front_max_radius", kFrontMaxRadius},
        {"mesh.max_hole_diameter_mm", kMaxHole},
        {"mesh.target_faces", kTargetFaces},
        {"mesh.fill", kFill},
        {"mesh.grid.pixel_step", kMeshStep},
    };
    const auto found = parameters.find(field);
    return QString::fromStdString(found == parameters.end() ? field : found->second);
}

// An error in the user's terms: "minModulation: must be 0..255" rather than the core's field.
QString user_message(const Error& error) {
    const std::string what = error.what();
    if (error.subject().empty()) return QString::fromStdString(what);
    return parameter_for_field(error.subject()) + ": " + QString::fromStdString(what.substr(error.subject().size() + 2));
}

DecodeOptions decode_options(const RichParameterList& parameters) {
    DecodeOptions options;
    options.binary_only = parameters.getBool(kBinaryOnly);
    options.min_contrast = parameters.getFloat(kMinContrast);
    options.min_modulation = parameters.getFloat(kMinModulation);
    return options;
}

void add_decode_parameters(RichParameterList& parameters) {
    const DecodeOptions defaults;
    parameters.addParam(RichBool(kBinaryOnly, defaults.binary_only, "Binary only",
                                 "Decode the Gray code only and ignore the phase-shift frames (coarser; for comparison)."));
    parameters.addParam(RichFloat(kMinContrast, float(defaults.min_contrast), "Min contrast (grey levels)",
                                  "Pixels whose white - black difference is below this are shadow or background."));
    parameters.addParam(RichFloat(kMinModulation, float(defaults.min_modulation), "Min modulation (grey levels)",
                                  "Pixels whose fringe amplitude is below this are rejected as unreliable."));
}

void add_output_parameters(RichParameterList& parameters) {
    parameters.addParam(RichEnum(kOutput, PointCloudLayer, QStringList{"Point cloud", "Grid mesh"}, "Layer",
                                 "Point cloud: coloured points with normals that keep their camera pixel, so the layer "
                                 "can be cleaned and aligned. Grid mesh: the pixel grid triangulated without bridging "
                                 "depth jumps."));
    parameters.addParam(RichInt(kMeshStep, GridMeshOptions{}.pixel_step, "Grid mesh step (pixels)",
                                "Grid mesh only: join every n-th pixel (n*n times fewer triangles)."));
}

// How a finished scan becomes a layer.
struct LayerRequest {
    OutputKind output = PointCloudLayer;
    MeshOptions grid_mesh;  // for GridMeshLayer
};

LayerRequest layer_request(const RichParameterList& parameters) {
    LayerRequest request;
    request.output = OutputKind(enum_choice(parameters, kOutput, 2));
    request.grid_mesh.method = MeshMethod::Grid;
    request.grid_mesh.grid.pixel_step = parameters.getInt(kMeshStep);
    validate(request.grid_mesh);
    return request;
}

// Adds a layer and fills it; a failure while filling removes it again, so no layer is left half-filled.
MeshModel* add_filled_layer(MeshDocument& document, const QString& label, const std::function<void(MeshModel&)>& fill) {
    MeshModel* layer = document.addNewMesh("", label, true);
    try {
        fill(*layer);
    } catch (...) {
        document.delMesh(layer);
        throw;
    }
    return layer;
}

MeshModel* add_scan_layer(MeshDocument& document, const QString& label, const ScanView& view,
                          const LayerRequest& request, const std::string& source) {
    if (request.output == GridMeshLayer) {
        const Mesh mesh = mesh_view(view, request.grid_mesh);
        if (mesh.faces.empty()) throw Error(source, "the grid mesh has no triangles");
        return add_filled_layer(document, label, [&](MeshModel& layer) { fill_layer(layer, mesh); });
    }
    return add_filled_layer(document, label, [&](MeshModel& layer) { fill_layer(layer, view); });
}

std::string layer_name(const MeshModel& layer) { return layer.label().toStdString(); }

// The "placements" parameter, layers per placement in layer order ("8 8"), as the core's
// placement_of_view; empty (one placement) when it is empty or names one placement.
std::vector<int> placement_of_layers(const QString& text, size_t layer_count) {
    std::vector<int> placement_of_view;
    const QStringList counts = text.split(QRegularExpression("[\\s,;]+"), Qt::SkipEmptyParts);
    for (int placement = 0; placement < counts.size(); ++placement) {
        bool number = false;
        const int count = counts[placement].toInt(&number);
        if (!number || count < 1)
            throw Error(kPlacements, "'" + counts[placement].toStdString() + "' is not a number of layers (1 or more)");
        placement_of_view.insert(placement_of_view.end(), size_t(count), placement);
    }
    if (!placement_of_view.empty() && placement_of_view.size() != layer_count)
        throw Error(kPlacements, "gives " + std::to_string(placement_of_view.size()) + " layers in all, but " +
                                     std::to_string(layer_count) + " PicoScan layers are visible");
    if (counts.size() < 2) placement_of_view.clear();
    return placement_of_view;
}

// Align Layers' mode, checked with the known axis' parameters, which only mode "Turntable axis" uses.
AlignMode align_mode(const RichParameterList& parameters) {
    const int mode = enum_choice(parameters, kAlignMode, TurntableAxisAlign + 1);
    const vcg::Point3f direction = parameters.getPoint3f(kTurntableAxisDirection);
    if (mode == TurntableAxisAlign && direction.Norm() == 0)
        throw Error(kTurntableAxisDirection, "must not be zero in mode 'Turntable axis': give the known axis' direction");
    if (mode != TurntableAxisAlign && (direction.Norm() != 0 || parameters.getFloat(kTurntableStep) != 0))
        throw Error(direction.Norm() != 0 ? kTurntableAxisDirection : kTurntableStep,
                    "is used in mode 'Turntable axis' only (a known axis): set that mode, or leave it zero");
    return AlignMode(mode);
}

// The known turntable axis of Align Layers (mode "Turntable axis"); the step defaults to one full
// round of a placement's layers.
TurntableAxis known_turntable_axis(const RichParameterList& parameters, const std::vector<int>& placement_of_view,
                                   size_t layer_count) {
    const vcg::Point3f point = parameters.getPoint3f(kTurntableAxisPoint);
    const vcg::Point3f direction = parameters.getPoint3f(kTurntableAxisDirection);
    const double step = parameters.getFloat(kTurntableStep);
    TurntableAxis axis{{point[0], point[1], point[2]}, {direction[0], direction[1], direction[2]}, step};
    if (step == 0) {
        std::vector<size_t> sizes(size_t(placement_of_view.empty() ? 1 : placement_of_view.back() + 1), 0);
        for (size_t i = 0; i < layer_count; ++i) ++sizes[placement_of_view.empty() ? 0 : size_t(placement_of_view[i])];
        if (std::any_of(sizes.begin(), sizes.end(), [&](size_t size) { return size != sizes.front(); }))
            throw Error(kTurntableStep, "give the step: the placements have different numbers of layers");
        axis.step_deg = 360.0 / double(sizes.front());
    }
    return axis;
}

// The DXF's name is checked before the cut, which may take a while: a wrong one would otherwise
// fail only after all the work, and a name without .dxf (a slip, or the mesh's own file) is no
// drawing to write over.
void check_section_dxf(const std::string& dxf) {
    const QFileInfo file(QString::fromStdString(dxf));
    if (file.suffix().compare("dxf", Qt::CaseInsensitive) != 0) throw Error(kSectionDxf, "'" + dxf + "' must end in .dxf");
    if (!file.absoluteDir().exists())
        throw Error(kSectionDxf, "the folder '" + file.absolutePath().toStdString() + "' does not exist");
}

}  // namespace

PicoScanFilterPlugin::PicoScanFilterPlugin() {
    typeList << Reconstruct << Simulate << Clean << Align << Fuse << Measure << SaveViews << Section;
    for (FilterIDType type : types()) actionList << new QAction(filterName(type), this);
}

QString PicoScanFilterPlugin::pluginName() const { return "FilterPicoScan"; }

QString PicoScanFilterPlugin::filterName(FilterIDType filter) const {
    switch (filter) {
    case Reconstruct: return "PicoScan: Reconstruct from Capture Set";
    case Simulate: return "PicoScan: Simulate Scan";
    case Clean: return "PicoScan: Clean Scan";
    case Align: return "PicoScan: Align Layers";
    case Fuse: return "PicoScan: Fuse and Mesh";
    case Measure: return "PicoScan: Measure Sphere or Plane";
    case SaveViews: return "PicoScan: Save Views for Project";
    case Section: return "PicoScan: Fit Cross-section";
    }
    return {};
}

QString PicoScanFilterPlugin::filterInfo(FilterIDType filter) const {
    switch (filter) {
    case Reconstruct:
        return "Decodes a structured-light capture set (Gray code + phase shift, hybrid unwrapping) and triangulates "
               "every camera pixel with the rig's calibration. Creates a new layer: a coloured point cloud with "
               "normals and quality (fringe modulation) that keeps each point's camera pixel, or a grid mesh.<br>"
               "The frame order comes from <i>sequence.json</i> in the capture folder, a manifest file, or a preset "
               "for capture sets made by SLMaster or SLStudio.<br>"
               "With a stereo calibration (two cameras), give the second camera's capture folder as well: each "
               "camera decodes the projector's codes, and the cameras are matched along rectified rows and "
               "triangulated (binocular structured light; the projector is not calibrated).";
    case Simulate:
        return "Simulates a scan with PicoScan's virtual rig (ray-cast camera and projector, noise, defocus) and "
               "reconstructs it into a new layer, for trying the tool without hardware. The scene is the built-in "
               "demo part or a scene file; the rig is the seed-like rig (1600x1200 camera, 854x480 projector) or a "
               "calibration file. The simulated capture set can be saved for <i>Reconstruct from Capture Set</i>.";
    case Clean:
        return "Removes unreliable points from a PicoScan point cloud layer, on its camera pixel grid: low quality, "
               "grazing angles, statistical and radius outliers, small disconnected clusters. The log says how many "
               "points each step removed.";
    case Align:
        return "Registers all visible PicoScan layers into one model: ORB features on the white frames lifted to 3D, "
               "a RANSAC rigid fit, point-to-plane ICP, then a global refinement of all views together. The first "
               "visible layer stays where it is; each other layer's transform is set. The mode chooses how each "
               "placement's layers are aligned: Automatic (features, then one turntable round with the axis "
               "estimated where features leave layers out: plain parts), Features, Turntable round, or a known "
               "Turntable axis. The log gives each way tried (layers aligned, the first left out and why, kept or "
               "not) and each layer's method, residual and overlap. If any layer cannot be aligned, no transform is "
               "changed.<br>"
               "Several placements (the part set down again between them, e.g. standing, then on its side to show "
               "the face it stood on): give the number of layers of each placement, in layer order. Each placement "
               "is aligned on its own, then the placements to each other by their shape alone; a placement that "
               "does not fit one way only, within the scan's noise and without putting points where another "
               "placement's camera saw through, is named with the reason and nothing is changed.";
    case Fuse:
        return "Merges the visible PicoScan layers (each through its transform) into one cloud and meshes it with "
               "CGAL: Poisson (watertight) or advancing front (open surfaces), fills small holes and checks the "
               "result. With Poisson, the fill decides what closes the side the scan never saw: Poisson's guess, a "
               "flat cap on the table, or nothing (left open). Creates a new layer whose vertex quality is 1 where "
               "the surface was measured and 0 where it was filled in; the log gives the mesh check (watertight, "
               "manifold, volume, share of the surface filled in).";
    case Measure:
        return "Fits a sphere or a plane (least squares) to the current layer's points, or to the selected ones, and "
               "writes centre, radius or normal, and the RMS residual to the log: for checking a scanner with a "
               "reference sphere or a flat plate.";
    case SaveViews:
        return "Writes every PicoScan layer as a PicoScan view PLY (its points with their camera pixels, the camera, "
               "normals, quality, colours and the layer's transform as the view's pose) into a folder, and makes it "
               "the layer's file: the core's format with the full camera, which picoscan and FreeCAD read. A saved "
               "project does not need it (MeshLab's PLY of a PicoScan layer keeps its pixels and camera), but a "
               "layer saved without them takes them from the view file beside it. Other layers are left as they are.";
    case Section:
        return "Cuts the current layer (a mesh, through its transform) with a plane across X, Y or Z and fits lines, "
               "arcs and circles to the cut, as FreeCAD's Cross-section and <i>picoscan section</i> do: the log gives "
               "each element (size, direction or radius with its standard error, residuals) and the pieces left out, "
               "and why; the profile can be written as DXF. Each element lies within a tolerance of its points: by "
               "default 5 x the noise of the <i>scan layer</i>, the point cloud the mesh was made from (measured on its "
               "points). Choose it: a Poisson or flattened mesh's cut has almost no noise (nanometres), which says "
               "nothing of the scan. A scan layer whose points do not lie on the mesh (another part's scan, or one moved) "
               "is refused. Choosing the current layer itself means no scan: the tolerance then comes from the "
               "cut, and the log says to set it yourself.";
    }
    return {};
}

MeshFilterInterface::FilterClass PicoScanFilterPlugin::getClass(QAction* action) {
    switch (ID(action)) {
    case Reconstruct:
    case Simulate: return MeshFilterInterface::MeshCreation;
    case Clean: return MeshFilterInterface::Cleaning;
    case Align: return MeshFilterInterface::RangeMap;
    case Fuse: return MeshFilterInterface::Remeshing;
    case Measure:
    case Section: return MeshFilterInterface::Measure;
    case SaveViews: return MeshFilterInterface::Layer;
    }
    return MeshFilterInterface::MeshCreation;
}

MeshFilterInterface::FILTER_ARITY PicoScanFilterPlugin::filterArity(QAction* action) const {
    switch (ID(action)) {
    case Reconstruct:
    case Simulate: return NONE;
    case Align:
    case Fuse:
    case SaveViews: return VARIABLE;
    default: return SINGLE_MESH;
    }
}

int PicoScanFilterPlugin::getPreConditions(QAction* action) const {
    switch (ID(action)) {
    case Clean:
    case Align:
    case Fuse: return MeshModel::MM_VERTCOORD | MeshModel::MM_VERTNORMAL;
    default: return MeshModel::MM_NONE;
    }
}

int PicoScanFilterPlugin::postCondition(QAction* action) const {
    switch (ID(action)) {
    case Clean: return MeshModel::MM_VERTNUMBER | MeshModel::MM_FACENUMBER;
    case Align: return MeshModel::MM_TRANSFMATRIX;
    case Measure:
    case Section:
    case SaveViews: return MeshModel::MM_NONE;
    default: return MeshModel::MM_ALL;
    }
}

int PicoScanFilterPlugin::getRequirements(QAction*) { return MeshModel::MM_NONE; }

void PicoScanFilterPlugin::initParameterSet(QAction* action, MeshDocument& document, RichParameterList& parameters) {
    switch (ID(action)) {
    case Reconstruct:
        parameters.addParam(RichString(kCaptureFolder, "", "Capture folder",
                                       "Folder with the capture set's images (and its sequence.json)."));
        parameters.addParam(RichString(kCalibrationFile, "", "Calibration file",
                                       "Camera-projector calibration (PicoScan YAML, SLMaster caliInfo.yml or "
                                       "SLStudio calibration.xml), or a stereo calibration of two cameras (PicoScan, "
                                       "OpenCV stereoCalibrate M1 D1 M2 D2 R T, ...): then the second camera's "
                                       "capture folder is needed too."));
        parameters.addParam(RichString(kSecondCaptureFolder, "", "Second capture folder (stereo)",
                                       "With a stereo calibration: the second camera's capture set of the same "
                                       "patterns. The two cameras are matched by the projector's codes and "
                                       "triangulated; the projector needs no calibration."));
        parameters.addParam(RichEnum(kSequence, OwnManifest,
                                     QStringList{"sequence.json in the capture folder",
                                                 "SLMaster sinus + complementary Gray code",
                                                 "SLStudio Gray code"},
                                     "Frame order",
                                     "Where the order and meaning of the frames comes from. The presets use the "
                                     "calibration's projector size."));
        parameters.addParam(RichString(kManifestFile, "", "Manifest file (optional)",
                                       "A sequence.json to use instead (e.g. written by 'picoscan manifest'); "
                                       "overrides the frame order."));
    {
        const ForeignPresetOptions preset;
        parameters.addParam(RichInt(kShifts, preset.shifts, "Phase shifts (SLMaster)",
                                    "Phase shifts per period of the SLMaster preset; 0: the preset's own."));
        parameters.addParam(RichInt(kPeriods, preset.periods, "Fringe periods (SLMaster)",
                                    "Fringe periods across the projector (SLMaster preset); 0: the preset's own."));
        parameters.addParam(RichInt(kGrayBits, preset.gray_bits, "Gray bits (SLStudio)",
                                    "Projected Gray code bits (SLStudio preset); 0: all."));
    }
        add_decode_parameters(parameters);
        add_output_parameters(parameters);
        break;
    case Simulate: {
        const SimulateOptions defaults;
        const PatternOptions& patterns = defaults.patterns;
        const SimulationOptions& simulation = defaults.camera;
        parameters.addParam(RichString(kSceneFile, "", "Scene file (optional)",
                                       "Scene description (YAML/JSON: spheres, planes, boxes, cylinders, meshes); "
                                       "empty: the built-in demo part."));
        parameters.addParam(RichInt(kPartView, -1, "Turntable view of the mechanical part",
                                    "Instead of the scene: view n of the built-in mechanical test part on a turntable "
                                    "(0..7: turned in 45 degree steps, 8: from above), for trying Align and Fuse; "
                                    "-1: not used. A part view is simulated with the turntable session's own "
                                    "patterns, exposure, blur and decoding (noise and seed still apply)."));
        parameters.addParam(RichString(kCalibrationFile, "", "Calibration file (optional)",
                                       "Rig to simulate; empty: the seed-like rig."));
        parameters.addParam(RichInt(kShifts, patterns.shifts, "Phase shifts", "Phase shifts per axis (3..64)."));
        parameters.addParam(RichInt(kPeriodBits, patterns.period_bits, "Period bits", "Fringe period = 2^n projector pixels."));
        parameters.addParam(RichFloat(kFullScale, float(simulation.full_scale_dn), "Full scale (grey levels)",
                                      "Camera level of a white-lit white surface facing the projector: the exposure."));
        parameters.addParam(RichFloat(kNoise, float(simulation.noise_sigma_dn), "Camera noise (grey levels)", "Gaussian noise sigma."));
        parameters.addParam(RichFloat(kBlur, float(simulation.blur_sigma_px), "Defocus blur (pixels)", "Gaussian blur sigma in camera pixels."));
        parameters.addParam(RichInt(kSeed, int(simulation.seed), "Noise seed", "The same seed renders the same images."));
        parameters.addParam(RichString(kSaveCaptures, "", "Save capture set to (optional)",
                                       "Also write the simulated images, sequence.json and calibration.yml into this "
                                       "folder (must be empty or new), for 'Reconstruct from Capture Set'."));
        add_decode_parameters(parameters);
        add_output_parameters(parameters);
        break;
    }
    case Clean: {
        const CleanOptions defaults;
        parameters.addParam(RichFloat(kMinQuality, float(defaults.min_quality), "Min quality",
                                      "Points whose quality (fringe modulation, grey levels) is below this go."));
        parameters.addParam(RichFloat(kMaxGrazing, float(defaults.max_grazing_deg), "Max grazing angle (deg)",
                                      "Points seen more obliquely than this go; 90 or more disables."));
        parameters.addParam(RichInt(kWindow, defaults.window_px, "Window (pixels)",
                                    "Neighbourhood: a (2w+1)x(2w+1) window of camera pixels."));
        parameters.addParam(RichFloat(kOutlierSigma, float(defaults.outlier_sigma), "Outlier sigma",
                                      "Statistical outliers: distance to the 4th neighbour beyond median + sigma * "
                                      "robust spread."));
        parameters.addParam(RichFloat(kRadiusFootprints, float(defaults.radius_footprints), "Radius (pixel footprints)",
                                      "Radius outliers: neighbours counted within this many pixel footprints."));
        parameters.addParam(RichInt(kMinNeighbours, defaults.min_neighbours, "Min neighbours",
                                    "Radius outliers: fewer neighbours than this within the radius go."));
        parameters.addParam(RichInt(kMinCluster, defaults.min_cluster_points, "Min cluster size (points)",
                                    "Disconnected clusters smaller than this go."));
        break;
    }
    case Align: {
        const RegistrationOptions defaults;
        parameters.addParam(RichInt(kOrbFeatures, defaults.orb_features, "ORB features per view",
                                    "Keypoints found on each layer's white frame for the coarse alignment."));
        parameters.addParam(RichFloat(kIcpMaxDistance, float(defaults.icp_max_distance_mm), "ICP max distance (mm)",
                                      "Point pairs farther apart than this are never used by ICP."));
        parameters.addParam(RichFloat(kAlignSpacing, float(defaults.sample_spacing_mm), "Sample spacing (mm)",
                                      "Points are thinned to about this spacing for ICP."));
        parameters.addParam(RichFloat(kMinOverlap, float(defaults.min_overlap), "Min overlap (fraction)",
                                      "Views overlapping less than this are not registered to each other."));
        parameters.addParam(RichString(kPlacements, "", "Layers per placement",
                                       "For a part scanned in several placements (set down again between them): the "
                                       "number of visible layers of each placement, in layer order, e.g. '8 8' for "
                                       "8 layers standing, then 8 on its side. Empty: all layers are one placement."));
        parameters.addParam(RichEnum(kAlignMode, AutomaticAlign,
                                     QStringList{"Automatic", "Features", "Turntable round", "Turntable axis"}, "Mode",
                                     "How each placement's layers are aligned. Automatic: features first; a placement "
                                     "they leave incomplete (a plain, unpainted part gives no features) is aligned "
                                     "again as one turntable round, and the way that aligns more of its layers is "
                                     "kept. Features: ORB features on the white frames (painted or textured parts). "
                                     "Turntable round: the layers of each placement are one full turntable round, in "
                                     "order, in equal steps; the axis is estimated from them. Turntable axis: the "
                                     "layers are turntable steps about the known axis below."));
        parameters.addParam(RichPoint3f(kTurntableAxisPoint, vcg::Point3f(0, 0, 0), "Turntable axis point (mm)",
                                        "Mode 'Turntable axis': a point on the known axis (e.g. as 'picoscan stitch' "
                                        "prints it), in the first layer's camera frame."));
        parameters.addParam(RichPoint3f(kTurntableAxisDirection, vcg::Point3f(0, 0, 0), "Turntable axis direction",
                                        "Mode 'Turntable axis': the known axis' direction (any length; the part turns "
                                        "right-handed about it from one layer to the next); each placement's layers "
                                        "are turntable steps about it. Zero in the other modes."));
        parameters.addParam(RichFloat(kTurntableStep, 0.f, "Turntable step (degrees)",
                                      "Mode 'Turntable axis': the turn between layers; 0: one full round (360 degrees "
                                      "/ the layers of a placement)."));
        break;
    }
    case Fuse: {
        const MeshOptions defaults;
        parameters.addParam(RichEnum(kMethod, PoissonMethod, QStringList{"Poisson (watertight)", "Advancing front (open)"},
                                     "Method", "Poisson gives a closed surface; advancing front keeps the scanned "
                                               "surface only."));
        parameters.addParam(RichEnum(kFill, 0, kFillNames, "Fill (Poisson)",
                                     "What closes the side the scan never saw (the face the part stood on). Poisson: "
                                     "Poisson's own smooth guess. Table: a flat cap on the table's plane (fitted to "
                                     "the rim of the unseen side), for a part standing on the turntable. Open: nothing "
                                     "invented, the unseen side stays open (the points contoured where they are, no "
                                     "Poisson; seconds). Vertex quality: 1 measured, 0 filled in."));
        parameters.addParam(RichFloat(kMeshSpacing, float(defaults.sample_spacing_mm), "Sample spacing (mm)",
                                      "The merged cloud is thinned to about this spacing first (0 keeps all)."));
        parameters.addParam(RichFloat(kPoissonTriangleSize, float(defaults.poisson_triangle_size),
                                      "Poisson triangle size (spacings)", "Triangle size in average point spacings."));
        parameters.addParam(RichFloat(kPoissonDistance, float(defaults.poisson_distance), "Poisson distance (spacings)",
                                      "How far the mesh may stray from the implicit surface, in point spacings."));
        parameters.addParam(RichFloat(kFrontMaxRadius, float(defaults.advancing_front_max_radius),
                                      "Advancing front max radius (spacings)",
                                      "Triangles with a larger circumradius are not made."));
        parameters.addParam(RichFloat(kMaxHole, float(defaults.max_hole_diameter_mm), "Max hole diameter (mm)",
                                      "Holes up to this size are filled."));
        parameters.addParam(RichInt(kTargetFaces, defaults.target_faces, "Target faces",
                                    "Simplify to about this many faces (0 keeps all)."));
        break;
    }
    case Measure:
        parameters.addParam(RichEnum(kShape, SphereShape, QStringList{"Sphere", "Plane"}, "Shape", "The shape to fit."));
        parameters.addParam(RichBool(kSelectedOnly, false, "Selected points only",
                                     "Fit only the selected vertices (e.g. the reference sphere, not its stand)."));
        parameters.addParam(RichBool(kModelFrame, true, "Apply layer transform",
                                     "Measure in model coordinates (after the layer's transform) rather than the "
                                     "camera frame."));
        break;
    case Section: {
        MeshModel* mesh = document.mm();
        const float middle = mesh != nullptr ? float((mesh->cm.Tr * mesh->cm.bbox.Center())[2]) : 0.0f;
        // The scan behind the mesh, by default the first point cloud of the document; else the mesh itself (no scan).
        MeshModel* scan = mesh;
        for (MeshModel* layer : document.meshList)
            if (layer != mesh && layer->cm.vn > 0 && layer->cm.fn == 0) {
                scan = layer;
                break;
            }
        parameters.addParam(RichEnum(kSectionAxis, SectionZ, QStringList{"X", "Y", "Z"}, "Across axis",
                                     "The plane is square to this axis of the model's coordinates. The drawing's x and y "
                                     "are those of the right (X: y, z), front (Y: x, z) or top (Z: x, y) view."));
        parameters.addParam(RichFloat(kSectionAt, middle, "At (mm)",
                                      "Where along the axis, in model coordinates (by default the middle of the layer for "
                                      "Z)."));
        parameters.addParam(RichMesh(kScanLayer, scan, document.meshList.empty() ? nullptr : &document,
                                     "Scan layer (its noise sets the tolerance)",
                                     "The point cloud the mesh was made from (a view or the aligned views): 5 x its noise "
                                     "is the default tolerance. The current layer itself: no scan (the tolerance from "
                                     "the cut; set it yourself)."));
        parameters.addParam(RichFloat(kSectionTolerance, 0.0f, "Tolerance (mm)",
                                      "Largest distance of a point to its element; 0: 5 x the noise of the scan layer "
                                      "(or of the cut, without one)."));
        parameters.addParam(RichFloat(kSectionBand, float(kDefaultSectionBandMm), "Band (mm)",
                                      "Each element is fitted again with 16 more cuts within +- this of the plane where "
                                      "they follow it (a pad's sides); 0: the one cut."));
        parameters.addParam(RichString(kSectionDxf, "", "DXF file",
                                       "Where to write the fitted profile (DXF R12, millimetres, in the drawing's x and "
                                       "y); empty: none."));
        break;
    }
    case SaveViews:
        parameters.addParam(RichString(kViewFolder, "", "Folder for the views",
                                       "Where the view files go: beside the project (e.g. the project's folder; made "
                                       "if missing). Empty: the folder of the project the document was opened from."));
        break;
    }
    (void)document;
}

bool PicoScanFilterPlugin::applyFilter(QAction* action, MeshDocument& document, const RichParameterList& parameters,
                                       vcg::CallBackPos* callback) {
    try {
        switch (ID(action)) {
        case Reconstruct: reconstruct(document, parameters, callback); break;
        case Simulate: simulate(document, parameters, callback); break;
        case Clean: clean(document, parameters); break;
        case Align: align(document, parameters, callback); break;
        case Fuse: fuse(document, parameters, callback); break;
        case Measure: measure(document, parameters); break;
        case SaveViews: save_views(document, parameters); break;
        case Section: section(document, parameters, callback); break;
        }
        return true;
    } catch (const Error& error) {
        // meshlabserver prints only the log, the GUI shows errorMessage: give both the same line.
        errorMessage = user_message(error);
        Log(GLLogStream::WARNING, "%s error: %s", qUtf8Printable(filterName(ID(action))), qUtf8Printable(errorMessage));
        return false;
    } catch (const std::exception& error) {
        // meshlabserver prints only the log, the GUI shows errorMessage: give both the same line.
        errorMessage = QString::fromStdString(error.what());
        Log(GLLogStream::WARNING, "%s error: %s", qUtf8Printable(filterName(ID(action))), qUtf8Printable(errorMessage));
        return false;
    }
}

void PicoScanFilterPlugin::require_scan_grid(MeshModel& layer) {
    LayerRepair repair;
    const std::string missing = missing_scan_data(layer, &repair);
    if (!missing.empty()) throw Error(layer_name(layer), missing);
    if (!repair.view_file.isEmpty())
        Log("PicoScan %s: pixel grid and camera taken from the view file %s", qUtf8Printable(layer.label()),
            qUtf8Printable(repair.view_file));
    if (repair.normals_from_grid > 0)
        Log("PicoScan %s: saved without normals; %d normals recomputed from the pixel grid (neighbouring pixels, "
            "towards the camera)",
            qUtf8Printable(layer.label()), repair.normals_from_grid);
}

// The visible layers, each of which must carry a pixel grid.
std::vector<MeshModel*> PicoScanFilterPlugin::visible_scan_layers(MeshDocument& document) {
    std::vector<MeshModel*> layers;
    for (MeshModel* layer : document.meshList)
        if (layer->isVisible()) {
            require_scan_grid(*layer);
            layers.push_back(layer);
        }
    return layers;
}

void PicoScanFilterPlugin::reconstruct(MeshDocument& document, const RichParameterList& parameters,
                                       vcg::CallBackPos* callback) {
    const std::string folder = parameter_text(parameters.getString(kCaptureFolder));
    const std::string calibration_file = parameter_text(parameters.getString(kCalibrationFile));
    if (folder.empty()) throw Error(kCaptureFolder, "is required: the folder of the capture set");
    if (calibration_file.empty()) throw Error(kCalibrationFile, "is required: the rig's calibration file");
    if (!QFileInfo(QString::fromStdString(folder)).isDir()) throw Error(folder, "capture folder not found");
    if (!QFileInfo(QString::fromStdString(calibration_file)).isFile()) throw Error(calibration_file, "calibration file not found");
    ReconstructOptions options;
    options.manifest_path = parameter_text(parameters.getString(kManifestFile));
    options.decode = decode_options(parameters);
    validate(options);
    const LayerRequest request = layer_request(parameters);

    const std::string second_folder = parameter_text(parameters.getString(kSecondCaptureFolder));
    if (calibration_kind(calibration_file) == CalibrationKind::Stereo) {
        if (second_folder.empty())
            throw Error(kSecondCaptureFolder, "is required: " + calibration_file +
                                                  " is a stereo calibration (two cameras); give the second camera's "
                                                  "capture folder");
        if (!QFileInfo(QString::fromStdString(second_folder)).isDir())
            throw Error(second_folder, "second capture folder not found");
        if (options.manifest_path.empty() && enum_choice(parameters, kSequence, SlstudioGray + 1) != OwnManifest)
            throw Error(kSequence, "the presets take the projector's size from a camera-projector calibration; with "
                                   "the stereo calibration " + calibration_file + " give a manifest file");
        StereoReconstructOptions stereo_options;
        stereo_options.manifest_path = options.manifest_path;
        stereo_options.decode = options.decode;
        const StereoCalibration calibration = read_stereo_calibration(calibration_file);
        const StereoReconstructResult result = reconstruct_stereo_view(
            folder, second_folder, calibration, calibration_file, stereo_options, meshlab_progress(callback));
        const QString label = QDir(QString::fromStdString(folder)).dirName();
        MeshModel* layer = add_scan_layer(document, (label.isEmpty() ? "PicoScan scan" : label) + " (stereo)",
                                          result.view, request, folder);
        Log("PicoScan reconstructed %s with the second camera's %s (stereo): %d points (%.1f %% of the camera "
            "pixels), %d faces; %d of %d decoded pixels matched, left-right consistency %.1f %%",
            folder.c_str(), second_folder.c_str(), result.point_count,
            100.0 * result.point_count / double(result.view.points.total()), layer->cm.fn, result.statistics.matched,
            result.statistics.left_decoded, 100.0 * result.statistics.left_right_consistency());
        return;
    }
    if (!second_folder.empty())
        throw Error(kSecondCaptureFolder, calibration_file + " is a camera-projector calibration; a second camera "
                                          "needs a stereo calibration of both cameras");
    const Calibration calibration = read_calibration(calibration_file);
    // Presets describe foreign capture sets: their manifest is written to a temporary folder.
    QTemporaryDir preset_folder;
    const int sequence = enum_choice(parameters, kSequence, SlstudioGray + 1);
    if (options.manifest_path.empty() && sequence != OwnManifest) {
        ForeignPresetOptions preset;
        preset.preset = sequence == SlmasterCgc ? "slmaster-cgc" : "slstudio-gray";
        preset.projector_size = calibration.projector_size;
        preset.shifts = parameters.getInt(kShifts);
        preset.periods = parameters.getInt(kPeriods);
        preset.gray_bits = parameters.getInt(kGrayBits);
        if (!preset_folder.isValid()) throw Error("temporary folder", "cannot be created for the preset's manifest");
        options.manifest_path = preset_folder.filePath("sequence.json").toStdString();
        write_manifest(foreign_preset_sequence(preset), options.manifest_path);
    }
    const ReconstructResult result =
        reconstruct_view(folder, calibration, calibration_file, options, meshlab_progress(callback));
    const QString label = QDir(QString::fromStdString(folder)).dirName();
    MeshModel* layer = add_scan_layer(document, label.isEmpty() ? "PicoScan scan" : label, result.view, request, folder);
    Log("PicoScan reconstructed %s: %d points (%.1f %% of the camera pixels), %d faces", folder.c_str(),
        result.point_count, 100.0 * result.point_count / double(result.view.points.total()), layer->cm.fn);
}

void PicoScanFilterPlugin::simulate(MeshDocument& document, const RichParameterList& parameters,
                                    vcg::CallBackPos* callback) {
    const std::string scene_file = parameter_text(parameters.getString(kSceneFile));
    const std::string calibration_file = parameter_text(parameters.getString(kCalibrationFile));
    const std::string save_folder = parameter_text(parameters.getString(kSaveCaptures));
    const Calibration calibration = calibration_file.empty() ? seed_rig_calibration() : read_calibration(calibration_file);
    const int part_view = parameters.getInt(kPartView);
    const TurntableScanOptions turntable;
    const std::vector<cv::Matx44d> turntable_poses = turntable_part_poses(turntable.plan);
    if (part_view < -1 || part_view >= int(turntable_poses.size()))
        throw Error(kPartView, "must be -1.." + std::to_string(turntable_poses.size() - 1));
    if (part_view >= 0 && !scene_file.empty()) throw Error(kPartView, "conflicts with the scene file; use one of them");
    if (parameters.getInt(kSeed) < 0) throw Error(kSeed, "must be >= 0");
    SimulateOptions simulation;
    ReconstructOptions reconstruction;
    Scene scene;
    if (part_view >= 0) {
        // One view of the core's turntable session, with its recipe: patterns, exposure, blur,
        // decoding and the part's albedo; each view's noise seeded apart, as in the session.
        simulation.patterns = turntable.patterns;
        simulation.camera = turntable.camera;
        reconstruction.decode = turntable.decode;
        scene.meshes.push_back({transformed(mechanical_part(), turntable_poses[size_t(part_view)]), turntable.part_albedo});
        simulation.camera.seed = uint64_t(parameters.getInt(kSeed)) + uint64_t(part_view);
    } else {
        scene = scene_file.empty() ? demo_scene() : read_scene(scene_file);
        simulation.patterns.shifts = parameters.getInt(kShifts);
        simulation.patterns.period_bits = parameters.getInt(kPeriodBits);
        simulation.camera.full_scale_dn = parameters.getFloat(kFullScale);
        simulation.camera.blur_sigma_px = parameters.getFloat(kBlur);
        simulation.camera.seed = uint64_t(parameters.getInt(kSeed));
        reconstruction.decode = decode_options(parameters);
    }
    simulation.camera.noise_sigma_dn = parameters.getFloat(kNoise);
    validate(simulation);
    validate(reconstruction);
    const LayerRequest request = layer_request(parameters);
    if (!save_folder.empty()) require_empty_directory(save_folder);

    const ProgressCallback progress = meshlab_progress(callback);
    const CaptureSet captures = simulate_captures(scene, calibration, simulation, progress);
    const std::string calibration_name = calibration_file.empty() ? "seed rig" : calibration_file;
    const ReconstructResult result = reconstruct_view(captures, calibration, calibration_name, reconstruction, progress);
    const std::string source = part_view >= 0 ? "mechanical part view " + std::to_string(part_view)
                               : scene_file.empty() ? "demo part" : scene_file;
    const QString label = part_view >= 0       ? QString("Part view %1").arg(part_view)
                          : scene_file.empty() ? "Simulated demo part"
                                               : "Simulated " + QFileInfo(QString::fromStdString(scene_file)).baseName();
    // The layer is made before anything is written, so a failed scan leaves no capture folder either.
    MeshModel* layer = add_scan_layer(document, label, result.view, request, source);
    if (!save_folder.empty()) {
        try {
            write_capture_set(captures, save_folder);
            write_calibration(calibration, QDir(QString::fromStdString(save_folder)).filePath("calibration.yml").toStdString());
        } catch (...) {
            document.delMesh(layer);
            throw;
        }
        Log("PicoScan simulated capture set (%zu frames) and calibration.yml written to %s", captures.images.size(),
            save_folder.c_str());
    }
    if (part_view >= 0)
        Log("PicoScan turntable recipe for the part view: %d shifts, full scale %.0f, blur %.2f px, min modulation %.0f, "
            "albedo %.2f, seed %d (the scene's pattern, exposure and decoding parameters are not used)",
            simulation.patterns.shifts, simulation.camera.full_scale_dn, simulation.camera.blur_sigma_px,
            reconstruction.decode.min_modulation, turntable.part_albedo, int(simulation.camera.seed));
    Log("PicoScan simulated %s: %d points, %d faces", source.c_str(), result.point_count, layer->cm.fn);
}

void PicoScanFilterPlugin::clean(MeshDocument& document, const RichParameterList& parameters) {
    CleanScanOptions scan_options;
    CleanOptions& options = scan_options.cleaning;
    options.min_quality = parameters.getFloat(kMinQuality);
    options.max_grazing_deg = parameters.getFloat(kMaxGrazing);
    options.window_px = parameters.getInt(kWindow);
    options.outlier_sigma = parameters.getFloat(kOutlierSigma);
    options.radius_footprints = parameters.getFloat(kRadiusFootprints);
    options.min_neighbours = parameters.getInt(kMinNeighbours);
    options.min_cluster_points = parameters.getInt(kMinCluster);
    validate(options);
    MeshModel& layer = *document.mm();
    require_scan_grid(layer);
    ScanView view = layer_view(layer);
    const CleanReport report = clean_scan(view, layer_name(layer), scan_options).report;
    const int deleted = remove_vertices_missing_from(layer, view);
    Log("PicoScan cleaned %s: removed %d points (%d low quality, %d grazing, %d outliers, %d with too few neighbours, "
        "%d in small clusters), %d remain",
        qUtf8Printable(layer.label()), deleted, report.by_quality, report.by_grazing, report.by_statistics,
        report.by_radius, report.by_cluster, layer.cm.vn);
}

void PicoScanFilterPlugin::align(MeshDocument& document, const RichParameterList& parameters, vcg::CallBackPos* callback) {
    StitchOptions options;
    options.registration.orb_features = parameters.getInt(kOrbFeatures);
    options.registration.icp_max_distance_mm = parameters.getFloat(kIcpMaxDistance);
    options.registration.sample_spacing_mm = parameters.getFloat(kAlignSpacing);
    options.registration.min_overlap = parameters.getFloat(kMinOverlap);
    const AlignMode mode = align_mode(parameters);
    options.automatic = mode == AutomaticAlign;
    options.registration.turntable_round = mode == TurntableRoundAlign;
    validate(options.registration);
    const std::vector<MeshModel*> layers = visible_scan_layers(document);
    if (layers.size() < 2) throw Error("Align Layers", "needs at least two visible PicoScan layers");
    options.placement_of_view = placement_of_layers(parameters.getString(kPlacements), layers.size());
    if (mode == TurntableAxisAlign)
        options.turntable = known_turntable_axis(parameters, options.placement_of_view, layers.size());
    validate(options);
    std::vector<ScanView> views;
    std::vector<std::string> names;
    for (MeshModel* layer : layers) {
        views.push_back(layer_view(*layer));
        views.back().pose = cv::Matx44d::eye();  // camera frame in; the result is relative to the first layer
        names.push_back(layer_name(*layer));
    }
    const StitchResult result = stitch_views(views, names, options, meshlab_progress(callback));
    // Every layer's and placement's outcome in the log, aligned or not, with the reason. A layer
    // of a placement that did not join is named through its placement.
    std::string failures;
    for (const StitchAttempt& attempt : result.attempts)
        Log("PicoScan placement %d by %s: %d of %d layers aligned%s%s; %s", attempt.placement + 1, attempt.method.c_str(),
            attempt.aligned_views, attempt.views, attempt.problem.empty() ? "" : ", first left out: ",
            attempt.problem.c_str(), attempt.kept ? "kept" : "not kept");
    const std::vector<PlacementAlignment>& placements = result.alignment.placements;
    for (size_t i = 0; i < layers.size(); ++i) {
        const ViewAlignment& view = result.alignment.views[i];
        if (view.aligned)
            Log("PicoScan aligned %s by %s: residual %.4f mm RMS, overlap %.1f %%", view.name.c_str(),
                result.method_of_view[i].c_str(), view.rms_mm, 100 * std::min(1.0, view.overlap));
        else if (placements.empty() || placements[size_t(view.placement)].aligned)
            failures += (failures.empty() ? "" : "; ") + view.name + ": " + view.problem;
    }
    for (size_t p = 0; p < placements.size(); ++p) {
        if (p == 0 && placements[p].aligned)
            Log("PicoScan %s: the model frame", placements[p].name.c_str());
        else if (placements[p].aligned)
            Log("PicoScan %s aligned to the others: residual %.4f mm RMS (its layers' own %.4f mm), overlap %.1f %%",
                placements[p].name.c_str(), placements[p].rms_mm, placements[p].noise_mm,
                100 * std::min(1.0, placements[p].overlap));
        else
            failures += (failures.empty() ? "" : "; ") + placements[p].name + " NOT aligned: " + placements[p].problem;
    }
    // All or nothing: a partly aligned set would look aligned in the viewer, and no layer is forced in.
    if (!failures.empty())
        throw Error("Align Layers", std::to_string(layers.size() - result.merged_views.size()) + " of " +
                                        std::to_string(layers.size()) + " layers could not be aligned, no transform "
                                        "changed (" + failures + ")");
    const cv::Matx44d first_layer_pose = layer_pose(*layers.front());
    for (size_t i = 0; i < layers.size(); ++i) set_layer_pose(*layers[i], first_layer_pose * result.alignment.views[i].pose);
    Log("PicoScan aligned %zu layers", layers.size());
}

void PicoScanFilterPlugin::fuse(MeshDocument& document, const RichParameterList& parameters, vcg::CallBackPos* callback) {
    MeshOptions options;
    options.method =
        enum_choice(parameters, kMethod, AdvancingFrontMethod + 1) == AdvancingFrontMethod ? MeshMethod::AdvancingFront : MeshMethod::Poisson;
    options.sample_spacing_mm = parameters.getFloat(kMeshSpacing);
    options.poisson_triangle_size = parameters.getFloat(kPoissonTriangleSize);
    options.poisson_distance = parameters.getFloat(kPoissonDistance);
    options.advancing_front_max_radius = parameters.getFloat(kFrontMaxRadius);
    options.max_hole_diameter_mm = parameters.getFloat(kMaxHole);
    options.target_faces = parameters.getInt(kTargetFaces);
    const int fill = enum_choice(parameters, kFill, int(kFillNames.size()));
    options.fill = kFills[fill];
    validate(options);
    const std::vector<MeshModel*> layers = visible_scan_layers(document);
    if (layers.empty()) throw Error("Fuse and Mesh", "needs at least one visible PicoScan layer");
    // Each layer's organised view (pose = the layer's transform) is rebuilt when the core asks
    // for it and let go once its points are merged: one pixel grid at a time, not a second copy
    // of every layer (32 full views would be 1.9 GB).
    const FuseResult fused = fuse_views(
        layers.size(), [&](size_t index) { return layer_view(*layers[index]); }, options, meshlab_progress(callback));
    const QString label = options.method == MeshMethod::AdvancingFront ? "Fused mesh (advancing front)"
                          : options.fill == MeshFill::Poisson        ? "Fused mesh (Poisson)"
                                                                     : "Fused mesh (Poisson, fill " + kFillNames[fill].toLower() + ")";
    add_filled_layer(document, label, [&](MeshModel& layer) { fill_layer(layer, fused.mesh); });
    Log("PicoScan fused %zu layers (%zu points) into %zu vertices, %zu faces; %s", layers.size(),
        fused.merged.points.size(), fused.mesh.vertices.size(), fused.mesh.faces.size(), fused.check.summary().c_str());
}

void PicoScanFilterPlugin::measure(MeshDocument& document, const RichParameterList& parameters) {
    MeshModel& layer = *document.mm();
    const bool selected_only = parameters.getBool(kSelectedOnly);
    const std::vector<cv::Vec3f> points = layer_points(layer, parameters.getBool(kModelFrame), selected_only);
    const std::string subject = layer.label().toStdString() + (selected_only ? " (selection)" : "");
    if (points.empty()) throw Error(subject, selected_only ? "no vertex is selected" : "the layer has no vertices");
    if (enum_choice(parameters, kShape, PlaneShape + 1) == SphereShape) {
        const SphereFit fit = fit_sphere(points);
        Log("PicoScan sphere fit of %s: centre %.4f %.4f %.4f mm, radius %.4f mm (diameter %.4f mm), RMS %.4f mm over "
            "%zu points",
            subject.c_str(), fit.centre[0], fit.centre[1], fit.centre[2], fit.radius_mm, 2 * fit.radius_mm, fit.rms_mm,
            fit.point_count);
    } else {
        const PlaneFit fit = fit_plane(points);
        Log("PicoScan plane fit of %s: normal %.7f %.7f %.7f, offset %.4f mm, RMS %.4f mm over %zu points",
            subject.c_str(), fit.normal[0], fit.normal[1], fit.normal[2], fit.offset_mm, fit.rms_mm, fit.point_count);
    }
}

void PicoScanFilterPlugin::save_views(MeshDocument& document, const RichParameterList& parameters) {
    QString folder = parameters.getString(kViewFolder).trimmed();
    const QString project = document.docLabel();
    if (folder.isEmpty()) {
        if (!project.endsWith(".mlp", Qt::CaseInsensitive) && !project.endsWith(".mlb", Qt::CaseInsensitive))
            throw Error(kViewFolder, "is required: the document was not opened from a project; give the folder the "
                                     "project will be saved in");
        folder = QFileInfo(project).absolutePath();
    }
    if (!QDir().mkpath(folder)) throw Error(folder.toStdString(), "folder for the views cannot be made");
    const QDir directory(folder);
    // Every file is chosen and checked before any is written.
    struct Planned {
        MeshModel* layer;
        QString path;
    };
    std::vector<Planned> planned;
    QStringList names;
    for (MeshModel* layer : document.meshList) {
        const std::string missing = missing_scan_data(*layer);
        if (!missing.empty()) {
            Log("PicoScan %s is not a PicoScan view, left as it is (%s)", qUtf8Printable(layer->label()), missing.c_str());
            continue;
        }
        QString base = QFileInfo(layer->label()).completeBaseName();
        if (layer->label().endsWith(".ply", Qt::CaseInsensitive) == false) base = layer->label();
        base.replace(QRegularExpression("[^A-Za-z0-9._-]+"), "_");
        if (base.isEmpty()) base = "view";
        QString name = base + ".ply";
        for (int n = 2; names.contains(name, Qt::CaseInsensitive); ++n) name = base + "_" + QString::number(n) + ".ply";
        names << name;
        const QString path = directory.absoluteFilePath(name);
        // Only the layer's own file is replaced: another file of that name may be someone's input.
        if (QFileInfo::exists(path) && QFileInfo(path).canonicalFilePath() != QFileInfo(layer->fullName()).canonicalFilePath())
            throw Error(path.toStdString(), "exists and is not the file of layer " + layer_name(*layer) +
                                                ": choose an empty folder for the views");
        planned.push_back({layer, path});
    }
    if (planned.empty()) throw Error("Save Views for Project", "no layer is a PicoScan view");
    for (const Planned& view : planned) {
        write_view_ply(layer_view(*view.layer), view.path.toStdString());  // the pose is the layer's transform
        view.layer->setFileName(view.path);
        Log("PicoScan saved %s (%d points) as %s", qUtf8Printable(view.layer->label()), view.layer->cm.vn,
            qUtf8Printable(view.path));
    }
    Log("PicoScan saved %zu views in %s", planned.size(), qUtf8Printable(folder));
}

void PicoScanFilterPlugin::section(MeshDocument& document, const RichParameterList& parameters, vcg::CallBackPos* callback) {
    const std::string dxf = parameter_text(parameters.getString(kSectionDxf));
    if (!dxf.empty()) check_section_dxf(dxf);
    if (!std::isfinite(parameters.getFloat(kSectionAt))) throw Error(kSectionAt, "must be a finite position in mm");
    MeshModel& layer = *document.mm();
    const Mesh mesh = layer_mesh(layer, true);
    if (mesh.faces.empty())
        throw Error(layer_name(layer), "has no triangles (a point cloud? mesh it first, e.g. with Fuse and Mesh)");
    MeshModel* scan_layer = parameters.getMesh(kScanLayer);
    const bool has_scan = scan_layer != nullptr && scan_layer != &layer;
    SectionFitOptions options;
    options.tolerance_mm = parameters.getFloat(kSectionTolerance);
    if (!(options.tolerance_mm >= 0) || !std::isfinite(options.tolerance_mm))
        throw Error(kSectionTolerance, "must be 0 (from the scan layer's noise) or a positive distance in mm");
    if (has_scan && options.tolerance_mm > 0)
        throw Error(kScanLayer, "sets the default tolerance: give a tolerance of 0, or choose the current layer (no scan)");
    PointCloud scan;
    if (has_scan) scan.points = layer_points(*scan_layer, true, false);

    const int axis = parameters.getEnum(kSectionAxis);
    const double at = parameters.getFloat(kSectionAt);
    const SectionPlane plane = section_plane_across(axis, at);  // picoscan section's right, front and top views
    MeshSectionFit result;
    try {
        result = section_mesh(mesh, plane.origin, plane.u, plane.v, parameters.getFloat(kSectionBand), options,
                              meshlab_progress(callback), has_scan ? &scan : nullptr);
    } catch (const Error& error) {
        const std::string why = std::string(error.what()).substr(error.subject().size() + 2);
        if (error.subject() == "scan") throw Error(kScanLayer, layer_name(*scan_layer) + ": " + why);
        if (error.subject() == "plane") throw Error(kSectionAt, why);
        if (error.subject() == "band_mm") throw Error(kSectionBand, why);
        throw;
    }
    if (!dxf.empty()) write_file_atomically(dxf, section_dxf(result.fits));

    const std::string name = layer_name(layer);
    const char* const axes[3] = {"x", "y", "z"};
    Log("PicoScan section of %s at %s = %.4f mm: %zu polylines fitted, %zu left out", name.c_str(), axes[axis], at,
        result.fits.fits.size(), result.fits.left_out.size());
    if (result.tolerance_source == SectionToleranceSource::ScanNoise)
        Log("PicoScan section of %s: the scan layer %s: %s", name.c_str(), layer_name(*scan_layer).c_str(),
            result.tolerance_from.c_str());
    else if (result.tolerance_source == SectionToleranceSource::CutNoise)
        Log(GLLogStream::WARNING, "PicoScan section of %s: no scan layer (the current layer was chosen): %s", name.c_str(),
            result.tolerance_from.c_str());
    else
        Log("PicoScan section of %s: %s", name.c_str(), result.tolerance_from.c_str());
    for (const std::string& line : result.report) Log("PicoScan section: %s", line.c_str());
    if (!dxf.empty()) Log("PicoScan section of %s written to %s", name.c_str(), dxf.c_str());
}

MESHLAB_PLUGIN_NAME_EXPORTER(PicoScanFilterPlugin)
