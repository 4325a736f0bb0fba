// picoscan patterns and manifest: the projector's frames, and sequences of other systems.
#include "cli_support.h"
#include "commands.h"

#include "picoscan/response.h"
#include "picoscan/calibration.h"
#include "picoscan/error.h"
#include "picoscan/file_output.h"

#include <cstdio>
#include <filesystem>

namespace fs = std::filesystem;

namespace picoscan::cli {

namespace {

const char* kPatternsHelp = R"(picoscan patterns --projector WxH --out DIR [options]

Writes one 8-bit PNG per projector frame, named in projection order, and DIR/sequence.json.
The sequence: white, black, Gray code bits of the projector columns (each followed by its
inverse), phase-shifted sinusoids of the columns, then the same for the rows.

  --projector WxH      projector resolution in pixels, e.g. 854x480 (required)
  --shifts K           phase shifts per axis, 3..64 (default 24; more shifts average out noise)
  --period-bits N      fringe period = 2^N projector pixels (default 4, i.e. 16 px)
  --rows | --no-rows   also encode projector rows (default --rows; rows allow ray-ray triangulation)
  --calibration FILE   apply the projector response correction stored in this calibration
                       (see 'picoscan response'), so the projected fringes are truly sinusoidal
  --flat-levels N      instead, write N (3..256) flat grey frames level_LLL.png from black to
                       white, for measuring the projector's response ('picoscan response')
  --out DIR            output folder (created if needed; must be empty or hold only patterns)

Example (show the frames full screen on the projector, in file-name order):
  picoscan patterns --projector 854x480 --out patterns/
)";

const char* kManifestHelp = R"(picoscan manifest --preset NAME --projector WxH --out FILE [options]

Writes a sequence.json that describes a capture set made by another system, so that
'picoscan reconstruct --manifest FILE' can read it in place.

  --preset opencv-graycode   OpenCV structured_light GrayCodePattern: (pattern, inverse) pairs,
                             columns then rows, then white, black. Files PREFIX<K>SUFFIX.
           --prefix P --suffix S --first-index K   (defaults: "", ".png", 1)
  --preset slstudio-gray     SLStudio Gray code: white, black, column bits without inverses
           --bits N          projected bits (default: all)
  --preset slstudio-phase-cue  SLStudio calibration sequence: 3-step fringes and a 3-step
                             one-period cue, columns then rows
           --periods N       fringe periods across the projector (default 16)
  --preset slmaster-cgc      SLMaster sinusoid + complementary Gray code
           --shifts K --periods N   (defaults 12 and 32)
  --projector WxH            the projector resolution of that system
  --out FILE                 the manifest to write (.json)

Example (OpenCV's structured_light pattern_cam1_im1.jpg ...; then reconstruct in place):
  picoscan manifest --preset opencv-graycode --projector 1280x800 \
                    --prefix pattern_cam1_im --suffix .jpg --out cam1.json
  picoscan reconstruct --calibration rig.yml --captures images/ --manifest cam1.json --out view.ply
)";

// Patterns and captures share file names, so a pattern folder is written only where it is
// new, empty, or holds patterns written before (marked): never over a capture set.
constexpr const char* kPatternsMarker = ".picoscan-patterns";

void require_pattern_folder(const std::string& directory) {
    std::error_code error;
    if (!fs::exists(directory, error)) return;
    if (!fs::is_directory(directory, error)) throw Error(directory, "exists and is not a folder");
    if (fs::is_empty(directory, error) || fs::is_regular_file(fs::path(directory) / kPatternsMarker, error)) return;
    throw Error(directory, "holds files that 'picoscan patterns' did not write (a capture set?); choose a new or "
                           "empty --out folder");
}

void mark_pattern_folder(const std::string& directory) {
    write_file_atomically((fs::path(directory) / kPatternsMarker).string(),
                          "made by picoscan patterns; the next patterns run may replace these files\n");
}

int run_patterns(const Arguments& arguments) {
    const PatternOptions options = pattern_options(arguments, arguments.size("--projector"));
    const std::string directory = arguments.required("--out");
    const cv::Mat response = arguments.has("--calibration")
                                 ? read_calibration(arguments.text("--calibration")).projector_inverse_response
                                 : cv::Mat();
    const int flat_levels = arguments.integer("--flat-levels", 0);
    arguments.reject_unknown();
    if (arguments.has("--flat-levels") && (flat_levels < 3 || flat_levels > 256))
        throw Error("--flat-levels", "must be 3..256 (grey levels of an 8-bit frame)");
    require_pattern_folder(directory);
    if (flat_levels > 0) {
        std::error_code ignored;
        fs::create_directories(directory, ignored);
        mark_pattern_folder(directory);
        for (int level : response_levels(flat_levels))
            write_image_file(cv::Mat(options.projector_size, CV_8U, cv::Scalar(level)),
                             (fs::path(directory) / flat_level_file(level)).string());
        std::printf("wrote %d flat frames level_LLL.png to %s\n", flat_levels, directory.c_str());
        return 0;
    }
    const PatternSequence sequence = make_pattern_sequence(options);
    std::error_code ignored;
    fs::create_directories(directory, ignored);
    mark_pattern_folder(directory);
    write_pattern_images(sequence, directory, response);
    std::printf("wrote %zu patterns (%d column bits, %d row bits, %d shifts, period %g px) and sequence.json to %s\n",
                sequence.frames.size(), sequence.columns.gray_bits, sequence.rows.gray_bits, options.shifts,
                sequence.columns.period_px, directory.c_str());
    return 0;
}

int run_manifest(const Arguments& arguments) {
    ForeignPresetOptions preset;
    preset.preset = arguments.required("--preset");
    preset.projector_size = arguments.size("--projector");
    const std::string out = arguments.required("--out");
    check_extension(out, {".json"}, "manifest (sequence.json)");
    preset.file_prefix = arguments.text("--prefix", preset.file_prefix);
    preset.file_suffix = arguments.text("--suffix", preset.file_suffix);
    preset.first_index = arguments.integer("--first-index", preset.first_index);
    preset.gray_bits = arguments.integer("--bits", preset.gray_bits);
    preset.periods = arguments.integer("--periods", preset.periods);
    preset.shifts = arguments.integer("--shifts", preset.shifts);
    arguments.reject_unknown();
    const PatternSequence sequence = foreign_preset_sequence(preset);
    write_manifest(sequence, out);
    std::printf("wrote %s (%zu frames, %s)\n", out.c_str(), sequence.frames.size(), preset.preset.c_str());
    return 0;
}

}  // namespace

PatternOptions pattern_options(const Arguments& arguments, cv::Size projector_size) {
    PatternOptions options;
    options.projector_size = projector_size;
    options.shifts = arguments.integer("--shifts", options.shifts);
    options.period_bits = arguments.integer("--period-bits", options.period_bits);
    if (arguments.flag("--rows") && arguments.flag("--no-rows")) throw Error("--rows", "conflicts with --no-rows");
    options.rows = !arguments.flag("--no-rows");
    validate(options);
    return options;
}

std::vector<Command> pattern_commands() {
    const ArgumentRules row_flags{{"--rows", "--no-rows"}, {}, false};
    return {
        {"patterns", "write the projector patterns (PNG) and their sequence.json manifest", kPatternsHelp, run_patterns,
         row_flags},
        {"manifest", "write a sequence.json describing a capture set made by another system", kManifestHelp,
         run_manifest, {}},
    };
}

}  // namespace picoscan::cli
