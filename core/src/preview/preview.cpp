#include "picoscan/preview.h"

#include "picoscan/error.h"
#include "picoscan/file_output.h"
#include "picoscan/simulate.h"
#include "register/point_grid.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

namespace picoscan {

cv::Mat render_preview(const ScanView& view) {
    const cv::Mat& points = view.points;
    std::vector<float> depths;
    depths.reserve(points.total() / 4);
    for (int y = 0; y < points.rows; ++y)
        for (int x = 0; x < points.cols; ++x)
            if (std::isfinite(points.at<cv::Vec3f>(y, x)[2])) depths.push_back(points.at<cv::Vec3f>(y, x)[2]);
    cv::Mat preview(points.size(), CV_8UC3, cv::Scalar(40, 40, 40));
    if (depths.empty()) return preview;
    // Robust depth range: the 2nd..98th percentiles, so a few stray points do not wash out the colours.
    std::sort(depths.begin(), depths.end());
    const float near = depths[depths.size() * 2 / 100], far = depths[depths.size() * 98 / 100];
    const float span = std::max(far - near, 1e-3f);

    cv::Mat depth_levels(points.size(), CV_8U, cv::Scalar(0));
    for (int y = 0; y < points.rows; ++y)
        for (int x = 0; x < points.cols; ++x) {
            const float z = points.at<cv::Vec3f>(y, x)[2];
            if (std::isfinite(z)) depth_levels.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(255 * (far - z) / span);
        }
    cv::Mat colours;
    cv::applyColorMap(depth_levels, colours, cv::COLORMAP_VIRIDIS);

    const cv::Vec3f light = cv::normalize(cv::Vec3f(-0.4f, -0.5f, -1.0f));  // from above-left of the camera
    for (int y = 0; y < points.rows; ++y)
        for (int x = 0; x < points.cols; ++x) {
            if (!std::isfinite(points.at<cv::Vec3f>(y, x)[2])) continue;
            const cv::Vec3f normal = view.normals.empty() ? cv::Vec3f(0, 0, -1) : view.normals.at<cv::Vec3f>(y, x);
            const float lambert = std::isfinite(normal[0]) ? std::max(0.0f, normal.dot(light)) : 0.5f;
            const float brightness = 0.25f + 0.75f * lambert;
            const cv::Vec3b colour = colours.at<cv::Vec3b>(y, x);
            preview.at<cv::Vec3b>(y, x) = cv::Vec3b(cv::saturate_cast<uint8_t>(colour[0] * brightness),
                                                    cv::saturate_cast<uint8_t>(colour[1] * brightness),
                                                    cv::saturate_cast<uint8_t>(colour[2] * brightness));
        }
    return preview;
}

void write_preview_png(const ScanView& view, const std::string& path) {
    write_image_file(render_preview(view), path);
}

void write_mesh_preview_png(const Mesh& mesh, const Calibration& camera, const std::string& path) {
    Scene scene;
    scene.meshes.push_back({mesh, 0.8});
    const Simulator simulator(camera, scene);
    ScanView view;
    view.points = simulator.geometry().points;
    view.normals = simulator.geometry().normals;
    cv::Mat seen(view.points.size(), CV_8U, cv::Scalar(0));
    for (int y = 0; y < seen.rows; ++y)
        for (int x = 0; x < seen.cols; ++x) seen.at<uint8_t>(y, x) = std::isfinite(view.points.at<cv::Vec3f>(y, x)[2]) ? 255 : 0;
    cv::Rect box = cv::boundingRect(seen);
    if (box.empty()) throw Error(path, "the mesh is not in the camera's view");
    const int margin = 40;
    box = cv::Rect(box.x - margin, box.y - margin, box.width + 2 * margin, box.height + 2 * margin) &
          cv::Rect(0, 0, view.points.cols, view.points.rows);
    cv::Mat image = render_preview(view);
    // Surface that was filled in, not measured (Mesh::measured), is shown in orange.
    if (mesh.measured.size() == mesh.vertices.size() && std::count(mesh.measured.begin(), mesh.measured.end(), 0) > 0) {
        std::vector<cv::Vec3d> vertices(mesh.vertices.begin(), mesh.vertices.end());
        const double reach_mm = 3.0;
        const detail::PointGrid grid(vertices, reach_mm);
        for (int y = box.y; y < box.y + box.height; ++y)
            for (int x = box.x; x < box.x + box.width; ++x) {
                const cv::Vec3f p = view.points.at<cv::Vec3f>(y, x);
                if (!std::isfinite(p[2])) continue;
                const int nearest = grid.nearest(cv::Vec3d(p), reach_mm);
                if (nearest < 0 || mesh.measured[static_cast<size_t>(nearest)]) continue;
                cv::Vec3b& pixel = image.at<cv::Vec3b>(y, x);
                const double level = (pixel[0] + pixel[1] + pixel[2]) / 3.0 / 255.0;
                pixel = cv::Vec3b(cv::saturate_cast<uint8_t>(40 * level), cv::saturate_cast<uint8_t>(150 * level + 40),
                                  cv::saturate_cast<uint8_t>(255 * level + 60));
            }
    }
    write_image_file(image(box), path);
}

namespace {

// One tile of the contact sheet: the mesh seen along `look` with `image_up` up, orthographic-like
// (a far camera), fitted to the mesh's bounding sphere; grey shading, filled surface orange.
cv::Mat render_tile(const Mesh& mesh, const cv::Vec3d& centre, double radius, const cv::Vec3d& look,
                    const cv::Vec3d& image_up, int size) {
    const cv::Vec3d z = cv::normalize(look), y = -cv::normalize(image_up - z * z.dot(image_up)), x = y.cross(z);
    const double distance = 20 * radius;
    cv::Matx44d to_camera = cv::Matx44d::eye();
    for (int c = 0; c < 3; ++c) {
        to_camera(0, c) = x[c];
        to_camera(1, c) = y[c];
        to_camera(2, c) = z[c];
    }
    const cv::Vec3d shift = -(cv::Matx33d(x[0], x[1], x[2], y[0], y[1], y[2], z[0], z[1], z[2]) * centre) + cv::Vec3d(0, 0, distance);
    for (int r = 0; r < 3; ++r) to_camera(r, 3) = shift[r];
    const Mesh seen = transformed(mesh, to_camera);
    Calibration camera;
    camera.camera_size = cv::Size(size, size);
    const double focal = 0.5 * size * distance / (1.1 * radius);
    camera.camera_matrix = cv::Matx33d(focal, 0, size / 2.0, 0, focal, size / 2.0, 0, 0, 1);
    camera.projector_size = camera.camera_size;
    camera.projector_matrix = camera.camera_matrix;
    Scene scene;
    scene.meshes.push_back({seen, 0.8});
    const Simulator simulator(camera, scene);
    const cv::Mat& points = simulator.geometry().points;
    const cv::Mat& normals = simulator.geometry().normals;
    const bool marks_filled = mesh.measured.size() == mesh.vertices.size() &&
                              std::count(mesh.measured.begin(), mesh.measured.end(), 0) > 0;
    std::vector<cv::Vec3d> vertices;  // the grid keeps a reference: it must outlive the grid
    if (marks_filled) vertices.assign(seen.vertices.begin(), seen.vertices.end());
    const double reach_mm = std::max(3.0, radius / 50);
    const detail::PointGrid grid(vertices, reach_mm);
    const cv::Vec3f light = cv::normalize(cv::Vec3f(-0.4f, -0.5f, -1.0f));
    cv::Mat tile(size, size, CV_8UC3, cv::Scalar(250, 250, 250));
    for (int row = 0; row < size; ++row)
        for (int col = 0; col < size; ++col) {
            const cv::Vec3f p = points.at<cv::Vec3f>(row, col);
            if (!std::isfinite(p[2])) continue;
            const cv::Vec3f n = normals.at<cv::Vec3f>(row, col);
            const float level = 0.2f + 0.8f * (std::isfinite(n[0]) ? std::abs(n.dot(light)) : 0.5f);
            bool filled = false;
            if (marks_filled) {
                const int nearest = grid.nearest(cv::Vec3d(p), reach_mm);
                filled = nearest >= 0 && !mesh.measured[static_cast<size_t>(nearest)];
            }
            const cv::Vec3f colour = filled ? cv::Vec3f(40, 150, 255) : cv::Vec3f(200, 200, 200);  // BGR
            tile.at<cv::Vec3b>(row, col) = cv::Vec3b(cv::saturate_cast<uint8_t>(colour[0] * level),
                                                     cv::saturate_cast<uint8_t>(colour[1] * level),
                                                     cv::saturate_cast<uint8_t>(colour[2] * level));
        }
    // Seen square to its faces, a part's steps and creases would vanish between faces of one shade:
    // its outline, steps (a depth jump of 3 pixels) and creases (normals 40 degrees apart) are drawn,
    // as in a drawing.
    const double pixel_mm = 1.1 * radius * 2 / size;
    // A pixel of the part on its edge: next to the background, to a surface farther behind it,
    // or to a face turned away from its own.
    const auto on_edge = [&](int row, int col) {
        const cv::Vec3f p = points.at<cv::Vec3f>(row, col), m = normals.at<cv::Vec3f>(row, col);
        for (const cv::Point step : {cv::Point(1, 0), cv::Point(-1, 0), cv::Point(0, 1), cv::Point(0, -1)}) {
            const int r = row + step.y, c = col + step.x;
            if (r < 0 || c < 0 || r >= size || c >= size) return true;
            const cv::Vec3f q = points.at<cv::Vec3f>(r, c), n = normals.at<cv::Vec3f>(r, c);
            if (!std::isfinite(q[2]) || q[2] - p[2] > 3 * pixel_mm) return true;
            if (std::isfinite(m[0]) && std::isfinite(n[0]) && m.dot(n) < std::cos(40.0f * float(CV_PI) / 180)) return true;
        }
        return false;
    };
    cv::Mat edges(size, size, CV_8U, cv::Scalar(0));
    for (int row = 0; row < size; ++row)
        for (int col = 0; col < size; ++col)
            if (std::isfinite(points.at<cv::Vec3f>(row, col)[2]) && on_edge(row, col)) edges.at<uint8_t>(row, col) = 1;
    tile.setTo(cv::Scalar(70, 70, 70), edges);
    return tile;
}

}  // namespace

ContactSheetAxes contact_sheet_axes(const Mesh& mesh, const cv::Vec3d& up_hint) {
    if (mesh.vertices.empty() || mesh.faces.empty()) throw Error("mesh", "has no triangles to show");
    cv::Vec3d centre(0, 0, 0);
    for (const cv::Vec3f& v : mesh.vertices) centre += cv::Vec3d(v);
    centre *= 1.0 / static_cast<double>(mesh.vertices.size());
    cv::Matx33d scatter = cv::Matx33d::zeros();
    for (const cv::Vec3f& v : mesh.vertices) {
        const cv::Vec3d d = cv::Vec3d(v) - centre;
        scatter += d * d.t();
    }
    // The part's own axes; "up" is the one nearest the hint (by default the camera's up, -y:
    // a turntable scan is in the first view's camera frame, looking down on the table).
    cv::Matx31d extents;
    cv::Matx33d axes;
    cv::eigen(scatter, extents, axes);
    const cv::Vec3d hint = cv::norm(up_hint) > 0 ? cv::normalize(up_hint) : cv::Vec3d(0, -1, 0);
    int up_row = 0;
    for (int r = 1; r < 3; ++r)
        if (std::abs(hint.dot(cv::Vec3d(axes(r, 0), axes(r, 1), axes(r, 2)))) >
            std::abs(hint.dot(cv::Vec3d(axes(up_row, 0), axes(up_row, 1), axes(up_row, 2)))))
            up_row = r;
    cv::Vec3d up(axes(up_row, 0), axes(up_row, 1), axes(up_row, 2));
    if (up.dot(hint) < 0) up = -up;
    const int front_row = up_row == 0 ? 1 : 0;  // the longest other axis
    cv::Vec3d front(axes(front_row, 0), axes(front_row, 1), axes(front_row, 2));

    // A machined part is best seen square to its faces, which its mass's axes are not (a hole, a
    // boss or a chamfer tilts them). Faces within 30 degrees of up (the top and the bottom) set up,
    // by their area-weighted mean normal; the faces square to it then set front, by the mean of
    // their directions taken four times round (so that faces 90 degrees apart agree). A part with
    // no dominant faces (a ball, a figure) keeps its mass's axes.
    const auto face_normals = [&](const auto& use) {
        for (const cv::Vec3i& f : mesh.faces) {
            const cv::Vec3d a(mesh.vertices[size_t(f[0])]), b(mesh.vertices[size_t(f[1])]), c(mesh.vertices[size_t(f[2])]);
            const cv::Vec3d doubled_area = (b - a).cross(c - a);
            const double area = cv::norm(doubled_area) / 2;
            if (area > 0) use(doubled_area * (0.5 / area), area);
        }
    };
    cv::Vec3d up_sum(0, 0, 0);
    double up_area = 0, total_area = 0;
    face_normals([&](const cv::Vec3d& n, double area) {
        total_area += area;
        if (std::abs(n.dot(up)) < std::sqrt(0.75) /* cos 30 deg */) return;
        up_sum += (n.dot(up) > 0 ? area : -area) * n;
        up_area += area;
    });
    if (up_area > 0.1 * total_area) up = cv::normalize(up_sum);
    front = cv::normalize(front - front.dot(up) * up);
    const cv::Vec3d across = up.cross(front);
    double c4 = 0, s4 = 0, side_area = 0;
    face_normals([&](const cv::Vec3d& n, double area) {
        if (std::abs(n.dot(up)) > 0.5 /* sin 30 deg */) return;
        const double angle = std::atan2(n.dot(across), n.dot(front));
        c4 += area * std::cos(4 * angle), s4 += area * std::sin(4 * angle), side_area += area;
    });
    if (side_area > 0.1 * total_area && std::hypot(c4, s4) > 0.3 * side_area) {
        const double turn = std::atan2(s4, c4) / 4;  // within 45 degrees of the mass's front
        front = std::cos(turn) * front + std::sin(turn) * across;
    }
    return {centre, up, front};
}

cv::Mat render_contact_sheet(const Mesh& mesh, const cv::Vec3d& up_hint, int tile_size) {
    const ContactSheetAxes axes = contact_sheet_axes(mesh, up_hint);
    const cv::Vec3d centre = axes.centre, up = axes.up, front = axes.front;
    double radius = 0;
    for (const cv::Vec3f& v : mesh.vertices) radius = std::max(radius, cv::norm(cv::Vec3d(v) - centre));
    const cv::Vec3d side = up.cross(front);
    struct Tile { const char* name; cv::Vec3d look, image_up; };
    const Tile tiles[] = {{"top", -up, front},     {"bottom", up, -front}, {"front", -front, up},
                          {"right", -side, up},    {"back", front, up},    {"left", side, up}};
    const int label_height = 28;
    cv::Mat sheet(2 * (tile_size + label_height), 3 * tile_size, CV_8UC3, cv::Scalar(255, 255, 255));
    for (int k = 0; k < 6; ++k) {
        const cv::Rect area((k % 3) * tile_size, (k / 3) * (tile_size + label_height) + label_height, tile_size, tile_size);
        render_tile(mesh, centre, radius, tiles[k].look, tiles[k].image_up, tile_size).copyTo(sheet(area));
        cv::putText(sheet, tiles[k].name, cv::Point(area.x + 8, area.y - 8), cv::FONT_HERSHEY_SIMPLEX, 0.7,
                    cv::Scalar(30, 30, 30), 2, cv::LINE_AA);
        cv::rectangle(sheet, area, cv::Scalar(180, 180, 180), 1);
    }
    cv::putText(sheet, "orange: filled in, not measured", cv::Point(3 * tile_size - 330, 2 * (tile_size + label_height) - 10),
                cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(40, 120, 230), 1, cv::LINE_AA);
    return sheet;
}

void write_contact_sheet_png(const Mesh& mesh, const std::string& path, const cv::Vec3d& up_hint) {
    write_image_file(render_contact_sheet(mesh, up_hint), path);
}

}  // namespace picoscan
