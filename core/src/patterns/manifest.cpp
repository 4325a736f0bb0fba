// sequence.json: the manifest that describes every frame of a capture set.
#include "picoscan/error.h"
#include "picoscan/file_output.h"
#include "picoscan/patterns.h"

#include "common/storage_file.h"

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <filesystem>

namespace picoscan {

namespace {

constexpr const char* kFormatName = "picoscan-sequence";
constexpr int kFormatVersion = 1;

void write_axis(cv::FileStorage& storage, const char* name, const AxisCode& code) {
    storage << name << "{";
    storage << "gray_bits" << code.gray_bits << "gray_unit_px" << code.gray_unit_px;
    storage << "shifts" << code.shifts << "period_px" << code.period_px;
    storage << "phase_offset_rad" << code.phase_offset_rad << "shift_sign" << code.shift_sign;
    if (code.cue_shifts > 0) storage << "cue_shifts" << code.cue_shifts << "cue_period_px" << code.cue_period_px;
    storage << "}";
}

// Typed access to manifest nodes, with errors naming the file and the key.
class ManifestReader {
public:
    explicit ManifestReader(const std::string& path) : path_(path) {}

    cv::FileNode require(const cv::FileNode& parent, const std::string& key) const {
        cv::FileNode node = parent[key];
        if (node.empty() || node.isNone()) fail("missing key '" + key + "'");
        return node;
    }
    int integer(const cv::FileNode& node, const std::string& key) const {
        if (!node.isInt()) fail("'" + key + "' must be an integer");
        return static_cast<int>(node);
    }
    double real(const cv::FileNode& node, const std::string& key) const {
        if (!node.isInt() && !node.isReal()) fail("'" + key + "' must be a number");
        const double value = static_cast<double>(node);
        if (!std::isfinite(value)) fail("'" + key + "' must be finite");
        return value;
    }
    std::string text(const cv::FileNode& node, const std::string& key) const {
        if (!node.isString()) fail("'" + key + "' must be a string");
        return static_cast<std::string>(node);
    }
    [[noreturn]] void fail(const std::string& problem) const { throw Error(path_, problem); }

private:
    std::string path_;
};

AxisCode read_axis(const ManifestReader& reader, const cv::FileNode& root, const std::string& name) {
    AxisCode code;
    cv::FileNode node = root[name];
    if (node.empty() || node.isNone()) return code;
    if (!node.isMap()) reader.fail("'" + name + "' must be a map");
    auto key = [&](const char* field) { return name + "." + field; };
    code.gray_bits = reader.integer(reader.require(node, "gray_bits"), key("gray_bits"));
    code.gray_unit_px = reader.real(reader.require(node, "gray_unit_px"), key("gray_unit_px"));
    code.shifts = reader.integer(reader.require(node, "shifts"), key("shifts"));
    code.period_px = reader.real(reader.require(node, "period_px"), key("period_px"));
    code.phase_offset_rad = reader.real(reader.require(node, "phase_offset_rad"), key("phase_offset_rad"));
    code.shift_sign = reader.integer(reader.require(node, "shift_sign"), key("shift_sign"));
    if (!node["cue_shifts"].empty()) {
        code.cue_shifts = reader.integer(node["cue_shifts"], key("cue_shifts"));
        code.cue_period_px = reader.real(reader.require(node, "cue_period_px"), key("cue_period_px"));
        if (code.cue_shifts < 3 || code.cue_shifts > 256) reader.fail("'" + key("cue_shifts") + "' must be 3..256");
        if (!(code.cue_period_px > code.period_px) || code.cue_period_px > 65536)
            reader.fail("'" + key("cue_period_px") + "' must be longer than period_px");
    }
    if (code.gray_bits < 0 || code.gray_bits > 24) reader.fail("'" + key("gray_bits") + "' must be 0..24");
    if (!(code.gray_unit_px > 0) || code.gray_unit_px > 65536) reader.fail("'" + key("gray_unit_px") + "' must be > 0");
    if (code.shifts != 0 && (code.shifts < 3 || code.shifts > 256)) reader.fail("'" + key("shifts") + "' must be 0 or 3..256");
    if (code.shifts > 0 && !(code.period_px >= 2 && code.period_px <= 65536)) reader.fail("'" + key("period_px") + "' must be 2..65536");
    if (code.shift_sign != 1 && code.shift_sign != -1) reader.fail("'" + key("shift_sign") + "' must be 1 or -1");
    return code;
}

FrameKind parse_kind(const ManifestReader& reader, const std::string& text, size_t index) {
    for (FrameKind kind :
         {FrameKind::White, FrameKind::Black, FrameKind::Gray, FrameKind::GrayInverse, FrameKind::Phase, FrameKind::Cue})
        if (to_string(kind) == text) return kind;
    reader.fail("frame " + std::to_string(index) + ": unknown kind '" + text +
                "' (white, black, gray, gray_inverse, phase or cue)");
}

}  // namespace

void write_manifest(const PatternSequence& sequence, const std::string& path) {
    cv::FileStorage storage("sequence.json", cv::FileStorage::WRITE | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_JSON);
    storage << "format" << kFormatName << "version" << kFormatVersion;
    storage << "origin" << sequence.origin;
    storage << "projector_width" << sequence.projector_size.width;
    storage << "projector_height" << sequence.projector_size.height;
    write_axis(storage, "columns", sequence.columns);
    if (sequence.rows.used()) write_axis(storage, "rows", sequence.rows);
    storage << "frames" << "[";
    for (const Frame& frame : sequence.frames) {
        storage << "{" << "file" << frame.file << "kind" << to_string(frame.kind) << "axis" << to_string(frame.axis);
        storage << "bit" << frame.bit << "shift" << frame.shift << "}";
    }
    storage << "]";
    write_file_atomically(path, storage.releaseAndGetString());
}

PatternSequence read_manifest(const std::string& path) {
    ManifestReader reader(path);
    const cv::FileStorage storage = detail::open_storage_file(path, "manifest", detail::StorageFormats::JsonOnly);
    try {
        const cv::FileNode root = storage.root();
        if (!root.isMap()) reader.fail("manifest must be a JSON object");
        if (reader.text(reader.require(root, "format"), "format") != kFormatName)
            reader.fail("'format' must be \"" + std::string(kFormatName) + "\"");
        const int version = reader.integer(reader.require(root, "version"), "version");
        if (version != kFormatVersion) reader.fail("unsupported manifest version " + std::to_string(version));

        PatternSequence sequence;
        sequence.origin = reader.text(reader.require(root, "origin"), "origin");
        sequence.projector_size.width = reader.integer(reader.require(root, "projector_width"), "projector_width");
        sequence.projector_size.height = reader.integer(reader.require(root, "projector_height"), "projector_height");
        if (sequence.projector_size.width < 2 || sequence.projector_size.height < 2 ||
            sequence.projector_size.width > 16384 || sequence.projector_size.height > 16384)
            reader.fail("projector size must be 2..16384 in each direction");
        sequence.columns = read_axis(reader, root, "columns");
        sequence.rows = read_axis(reader, root, "rows");
        if (!sequence.columns.used()) reader.fail("'columns' must encode the projector columns");

        const cv::FileNode frames = reader.require(root, "frames");
        if (!frames.isSeq() || frames.size() == 0) reader.fail("'frames' must be a non-empty list");
        if (frames.size() > 4096) reader.fail("'frames' lists more than 4096 frames");
        for (size_t index = 0; index < frames.size(); ++index) {
            const cv::FileNode node = frames[static_cast<int>(index)];
            const std::string where = "frames[" + std::to_string(index) + "]";
            if (!node.isMap()) reader.fail(where + " must be an object");
            Frame frame;
            frame.file = reader.text(reader.require(node, "file"), where + ".file");
            if (frame.file.empty() || frame.file.find('/') != std::string::npos || frame.file == "." || frame.file == "..")
                reader.fail(where + ".file must be a plain file name");
            frame.kind = parse_kind(reader, reader.text(reader.require(node, "kind"), where + ".kind"), index);
            const std::string axis = reader.text(reader.require(node, "axis"), where + ".axis");
            if (axis != "columns" && axis != "rows") reader.fail(where + ".axis must be columns or rows");
            frame.axis = axis == "columns" ? Axis::Columns : Axis::Rows;
            frame.bit = reader.integer(reader.require(node, "bit"), where + ".bit");
            frame.shift = reader.integer(reader.require(node, "shift"), where + ".shift");
            const AxisCode& code = sequence.code(frame.axis);
            if ((frame.kind == FrameKind::Gray || frame.kind == FrameKind::GrayInverse) &&
                (frame.bit < 0 || frame.bit >= code.gray_bits))
                reader.fail(where + ".bit " + std::to_string(frame.bit) + " is outside the " + to_string(frame.axis) +
                            " Gray code (" + std::to_string(code.gray_bits) + " bits)");
            if (frame.kind == FrameKind::Cue && (frame.shift < 0 || frame.shift >= code.cue_shifts))
                reader.fail(where + ".shift " + std::to_string(frame.shift) + " is outside the " + to_string(frame.axis) +
                            " cue shifts (" + std::to_string(code.cue_shifts) + ")");
            if (frame.kind == FrameKind::Phase && (frame.shift < 0 || frame.shift >= code.shifts))
                reader.fail(where + ".shift " + std::to_string(frame.shift) + " is outside the " + to_string(frame.axis) +
                            " phase shifts (" + std::to_string(code.shifts) + ")");
            sequence.frames.push_back(frame);
        }
        return sequence;
    } catch (const cv::Exception& error) {
        reader.fail("malformed manifest (" + error.err + ")");
    } catch (const std::bad_alloc&) {
        reader.fail("malformed manifest (implausible sizes)");
    }
}

void write_pattern_images(const PatternSequence& sequence, const std::string& directory, const cv::Mat& response_lut) {
    std::error_code error;
    std::filesystem::create_directories(directory, error);
    if (!std::filesystem::is_directory(directory)) throw Error(directory, "cannot create the output directory");
    for (const Frame& frame : sequence.frames)
        write_image_file(render_pattern(sequence, frame, response_lut),
                         (std::filesystem::path(directory) / frame.file).string());
    write_manifest(sequence, (std::filesystem::path(directory) / "sequence.json").string());
}

}  // namespace picoscan
