// Scene description files (YAML or JSON through OpenCV FileStorage).
//
//   spheres:   [{centre: [x, y, z], radius_mm: r, albedo: a}]
//   planes:    [{point: [x, y, z], normal: [x, y, z], albedo: a}]
//   boxes:     [{centre: [..], half_size_mm: [..], rotation: 3x3 | rotation_deg: [rx, ry, rz], albedo: a}]
//   cylinders: [{base_centre: [..], axis: [..], radius_mm: r, height_mm: h, albedo: a}]
//   meshes:    [{file: part.stl, albedo: a, translation: [x, y, z]}]
//   boards:    [{translation: [..], rotation: 3x3 | rotation_deg: [rx, ry, rz], inner_corners: [w, h],
//                square_mm: s, margin_mm: m, dark_albedo: a, light_albedo: a}]
// Every list is optional; albedo defaults to 0.8, board keys other than translation to
// CalibrationBoard's defaults. The "%YAML:1.0" header OpenCV wants is optional. rotation_deg turns about x, then y, then z
// (R = Rz * Ry * Rx). Mesh files are relative to the scene file.
#include "picoscan/simulate.h"

#include "picoscan/error.h"
#include "picoscan/io.h"

#include "common/storage_file.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <string>

namespace picoscan {

namespace {

class SceneReader {
public:
    explicit SceneReader(std::string path) : path_(std::move(path)) {}

    [[noreturn]] void fail(const std::string& where, const std::string& problem) const {
        throw Error(path_, where.empty() ? problem : where + ": " + problem);
    }

    double number(const cv::FileNode& item, const std::string& where, const std::string& key) const {
        const cv::FileNode node = item[key];
        if (node.empty() || node.isNone()) fail(where, "'" + key + "' is missing");
        if (!node.isInt() && !node.isReal()) fail(where, "'" + key + "' must be a number");
        const double value = static_cast<double>(node);
        if (!std::isfinite(value)) fail(where, "'" + key + "' must be finite");
        return value;
    }
    double optional_number(const cv::FileNode& item, const std::string& where, const std::string& key,
                           double fallback) const {
        const cv::FileNode node = item[key];
        return (node.empty() || node.isNone()) ? fallback : number(item, where, key);
    }
    double positive(const cv::FileNode& item, const std::string& where, const std::string& key) const {
        const double value = number(item, where, key);
        if (!(value > 0)) fail(where, "'" + key + "' must be positive");
        return value;
    }
    double albedo(const cv::FileNode& item, const std::string& where) const {
        return reflectance(item, where, "albedo", 0.8);
    }
    std::vector<double> numbers(const cv::FileNode& node, const std::string& where, const std::string& key) const {
        if (!node.isSeq()) fail(where, "'" + key + "' must be a list of numbers");
        std::vector<double> values;
        for (const cv::FileNode& element : node) {
            if (!element.isInt() && !element.isReal()) fail(where, "'" + key + "' must be a list of numbers");
            values.push_back(static_cast<double>(element));
            if (!std::isfinite(values.back())) fail(where, "'" + key + "' must be finite");
        }
        return values;
    }
    cv::Vec3d vec3(const cv::FileNode& item, const std::string& where, const std::string& key) const {
        const cv::FileNode node = item[key];
        if (node.empty() || node.isNone()) fail(where, "'" + key + "' is missing");
        const std::vector<double> v = numbers(node, where, key);
        if (v.size() != 3) fail(where, "'" + key + "' must have 3 numbers [x, y, z]");
        return {v[0], v[1], v[2]};
    }
    cv::Vec3d nonzero_vec3(const cv::FileNode& item, const std::string& where, const std::string& key) const {
        const cv::Vec3d v = vec3(item, where, key);
        if (!(cv::norm(v) > 0)) fail(where, "'" + key + "' must not be the zero vector");
        return v;
    }

    cv::Matx33d rotation(const cv::FileNode& item, const std::string& where) const {
        const cv::FileNode matrix_node = item["rotation"];
        const cv::FileNode degrees_node = item["rotation_deg"];
        const bool has_matrix = !matrix_node.empty() && !matrix_node.isNone();
        const bool has_degrees = !degrees_node.empty() && !degrees_node.isNone();
        if (has_matrix && has_degrees) fail(where, "give either 'rotation' or 'rotation_deg', not both");
        if (has_degrees) {
            const std::vector<double> d = numbers(degrees_node, where, "rotation_deg");
            if (d.size() != 3) fail(where, "'rotation_deg' must have 3 angles [rx, ry, rz]");
            const double k = CV_PI / 180.0;
            const double cx = std::cos(d[0] * k), sx = std::sin(d[0] * k);
            const double cy = std::cos(d[1] * k), sy = std::sin(d[1] * k);
            const double cz = std::cos(d[2] * k), sz = std::sin(d[2] * k);
            const cv::Matx33d rx(1, 0, 0, 0, cx, -sx, 0, sx, cx);
            const cv::Matx33d ry(cy, 0, sy, 0, 1, 0, -sy, 0, cy);
            const cv::Matx33d rz(cz, -sz, 0, sz, cz, 0, 0, 0, 1);
            return rz * ry * rx;
        }
        if (!has_matrix) return cv::Matx33d::eye();

        std::vector<double> values;
        if (matrix_node.isMap()) {  // OpenCV's !!opencv-matrix
            cv::Mat m;
            try {
                matrix_node >> m;
            } catch (const cv::Exception&) {
                fail(where, "'rotation' is not a readable matrix");
            }
            if (m.total() != 9 || m.channels() != 1) fail(where, "'rotation' must be 3x3");
            m.convertTo(m, CV_64F);
            values.assign(m.begin<double>(), m.end<double>());
        } else if (matrix_node.isSeq() && matrix_node.size() == 3 && matrix_node[0].isSeq()) {  // [[..], [..], [..]]
            for (const cv::FileNode& row : matrix_node) {
                const std::vector<double> r = numbers(row, where, "rotation");
                if (r.size() != 3) fail(where, "'rotation' must be 3x3");
                values.insert(values.end(), r.begin(), r.end());
            }
        } else {
            values = numbers(matrix_node, where, "rotation");  // 9 numbers, row by row
        }
        if (values.size() != 9) fail(where, "'rotation' must be 3x3");
        cv::Matx33d r(values.data());
        // Hand-written matrices carry few decimals: accept near-rotations, snap them exactly.
        if (!(cv::norm(r.t() * r - cv::Matx33d::eye()) < 1e-3) || !(cv::determinant(r) > 0))
            fail(where, "'rotation' is not a rotation matrix");
        cv::Mat u, w, vt;
        cv::SVD::compute(cv::Mat(r), w, u, vt);
        return cv::Matx33d(cv::Mat(u * vt));
    }

    cv::FileNode list(const cv::FileNode& root, const std::string& key) const {
        const cv::FileNode node = root[key];
        if (node.empty() || node.isNone()) return cv::FileNode();
        if (!node.isSeq()) fail("", "'" + key + "' must be a list");
        return node;
    }

    // A fraction of light, 0..1, defaulting to `fallback`.
    double reflectance(const cv::FileNode& item, const std::string& where, const std::string& key,
                       double fallback) const {
        const double value = optional_number(item, where, key, fallback);
        if (!(value >= 0 && value <= 1)) fail(where, "'" + key + "' must be within 0..1");
        return value;
    }

    const std::string& path() const { return path_; }

private:
    std::string path_;
};

}  // namespace

Scene read_scene(const std::string& path) {
    const SceneReader reader(path);
    const cv::FileStorage storage = detail::open_storage_file(path, "scene file", detail::StorageFormats::Any);
    const cv::FileNode root = storage.root();
    if (!root.isMap()) throw Error(path, "expected a map with lists of spheres, planes, boxes, cylinders, meshes, boards");

    const std::set<std::string> known = {"spheres", "planes", "boxes", "cylinders", "meshes", "boards"};
    for (const std::string& key : root.keys())
        if (!known.count(key))
            throw Error(path, "unknown key '" + key + "' (expected spheres, planes, boxes, cylinders, meshes, boards)");

    Scene scene;
    auto each = [&](const std::string& key, auto&& read_item) {
        const cv::FileNode items = reader.list(root, key);
        if (items.empty()) return;
        int index = 0;
        for (const cv::FileNode& item : items) {
            const std::string where = key + "[" + std::to_string(index++) + "]";
            if (!item.isMap()) reader.fail(where, "must be a map of keys");
            read_item(item, where);
        }
    };

    each("spheres", [&](const cv::FileNode& item, const std::string& where) {
        Sphere s;
        s.centre = reader.vec3(item, where, "centre");
        s.radius_mm = reader.positive(item, where, "radius_mm");
        s.albedo = reader.albedo(item, where);
        scene.spheres.push_back(s);
    });
    each("planes", [&](const cv::FileNode& item, const std::string& where) {
        Plane p;
        p.point = reader.vec3(item, where, "point");
        p.normal = cv::normalize(reader.nonzero_vec3(item, where, "normal"));
        p.albedo = reader.albedo(item, where);
        scene.planes.push_back(p);
    });
    each("boxes", [&](const cv::FileNode& item, const std::string& where) {
        Box b;
        b.centre = reader.vec3(item, where, "centre");
        b.half_size_mm = reader.vec3(item, where, "half_size_mm");
        if (!(b.half_size_mm[0] > 0 && b.half_size_mm[1] > 0 && b.half_size_mm[2] > 0))
            reader.fail(where, "'half_size_mm' must be positive");
        b.rotation = reader.rotation(item, where);
        b.albedo = reader.albedo(item, where);
        scene.boxes.push_back(b);
    });
    each("cylinders", [&](const cv::FileNode& item, const std::string& where) {
        Cylinder c;
        c.base_centre = reader.vec3(item, where, "base_centre");
        c.axis = cv::normalize(reader.nonzero_vec3(item, where, "axis"));
        c.radius_mm = reader.positive(item, where, "radius_mm");
        c.height_mm = reader.positive(item, where, "height_mm");
        c.albedo = reader.albedo(item, where);
        scene.cylinders.push_back(c);
    });
    const std::filesystem::path folder = std::filesystem::path(path).parent_path();
    each("meshes", [&](const cv::FileNode& item, const std::string& where) {
        const cv::FileNode file_node = item["file"];
        if (file_node.empty() || file_node.isNone()) reader.fail(where, "'file' is missing");
        if (!file_node.isString()) reader.fail(where, "'file' must be a file name");
        const std::string file = static_cast<std::string>(file_node);
        if (file.empty()) reader.fail(where, "'file' is empty");
        std::filesystem::path mesh_path(file);
        if (mesh_path.is_relative()) mesh_path = folder / mesh_path;

        TriangleMesh mesh;
        mesh.albedo = reader.albedo(item, where);
        const cv::FileNode translation_node = item["translation"];
        const cv::Vec3d translation = (translation_node.empty() || translation_node.isNone())
                                          ? cv::Vec3d(0, 0, 0)
                                          : reader.vec3(item, where, "translation");
        mesh.mesh = read_mesh(mesh_path.string());  // throws Error naming the mesh file
        if (mesh.mesh.faces.empty()) reader.fail(where, "'file' " + mesh_path.string() + " has no triangles");
        for (cv::Vec3f& v : mesh.mesh.vertices)
            v = cv::Vec3f(cv::Vec3d(v[0], v[1], v[2]) + translation);
        scene.meshes.push_back(std::move(mesh));
    });
    each("boards", [&](const cv::FileNode& item, const std::string& where) {
        CalibrationBoard b;
        b.translation = reader.vec3(item, where, "translation");
        b.rotation = reader.rotation(item, where);
        const cv::FileNode corners_node = item["inner_corners"];
        if (!corners_node.empty() && !corners_node.isNone()) {
            const std::vector<double> corners = reader.numbers(corners_node, where, "inner_corners");
            if (corners.size() != 2) reader.fail(where, "'inner_corners' must have 2 counts [w, h]");
            for (double count : corners)
                if (count != std::floor(count) || count < 2 || count > 10000)
                    reader.fail(where, "'inner_corners' must be whole numbers of at least 2");
            b.inner_corners = cv::Size(static_cast<int>(corners[0]), static_cast<int>(corners[1]));
        }
        b.square_mm = reader.optional_number(item, where, "square_mm", b.square_mm);
        if (!(b.square_mm > 0)) reader.fail(where, "'square_mm' must be positive");
        b.margin_mm = reader.optional_number(item, where, "margin_mm", b.margin_mm);
        if (!(b.margin_mm >= 0)) reader.fail(where, "'margin_mm' must not be negative");
        b.dark_albedo = reader.reflectance(item, where, "dark_albedo", b.dark_albedo);
        b.light_albedo = reader.reflectance(item, where, "light_albedo", b.light_albedo);
        scene.boards.push_back(b);
    });
    return scene;
}

}  // namespace picoscan
