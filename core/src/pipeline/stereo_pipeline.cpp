// The binocular reconstruction recipe (pipeline.h).
#include "picoscan/pipeline.h"

#include "picoscan/error.h"

namespace picoscan {

StereoReconstructResult reconstruct_stereo_view(const std::string& first_folder, const std::string& second_folder,
                                                const StereoCalibration& calibration, const std::string& calibration_name,
                                                const StereoReconstructOptions& options, const ProgressCallback& progress) {
    validate(options.decode);
    if (options.clean) validate(options.cleaning);
    validate_stereo_calibration(calibration, calibration_name);
    auto load = [&](const std::string& folder, const std::string& manifest, cv::Size size, const char* key) {
        CaptureSet captures = load_capture_set(folder, manifest, progress);
        const cv::Size found = captures.images.front().size();
        if (found != size)
            throw Error(calibration_name, std::string(key) + " is " + std::to_string(size.width) + "x" +
                                              std::to_string(size.height) + " but the captures in " + folder + " are " +
                                              std::to_string(found.width) + "x" + std::to_string(found.height));
        return captures;
    };
    const CaptureSet first = load(first_folder, options.manifest_path, calibration.left_size, "camera1_size");
    const CorrespondenceMap first_map = decode(first, options.decode, progress);
    const CorrespondenceMap second_map = decode(load(second_folder,
                                                         options.second_manifest_path.empty() ? options.manifest_path
                                                                                              : options.second_manifest_path,
                                                         calibration.right_size, "camera2_size"), options.decode, progress);
    StereoReconstructResult result;
    StereoCalibration used = calibration;
    if (options.refine_pose) {
        result.refinement = refine_stereo_extrinsics(first_map, second_map, calibration);
        used = result.refinement->calibration;
    }
    const StereoMatcher matcher = options.projector ? StereoMatcher(used, *options.projector) : StereoMatcher(used);
    StereoReconstruction reconstruction = matcher.reconstruct(first_map, second_map, first.white_colour, options.stereo, progress);
    result.view = std::move(reconstruction.view);
    result.statistics = reconstruction.statistics;
    if (options.clean) result.cleaning = clean_view(result.view, options.cleaning);
    result.point_count = result.view.valid_count();
    if (result.point_count == 0) throw Error(first_folder, "no pixel could be matched between the cameras and triangulated");
    return result;
}

}  // namespace picoscan
