// 3MF (3D Manufacturing Format) through lib3mf 1.8 (Debian's lib3mf-dev): one mesh object,
// one build item, units millimetres; written to memory, then atomically to the file.
#include "io/io_detail.h"
#include "picoscan/error.h"
#include "picoscan/file_output.h"
#include "picoscan/io.h"

#include <Model/COM/NMR_DLLInterfaces.h>

#include <string>
#include <vector>

namespace picoscan {

namespace {

using namespace NMR;

// Releases a lib3mf object when it goes out of scope.
class Handle {
public:
    Handle() = default;
    ~Handle() {
        if (object_) lib3mf_release(object_);
    }
    Handle(const Handle&) = delete;
    Handle& operator=(const Handle&) = delete;
    template <class T>
    T** out() {
        return reinterpret_cast<T**>(&object_);
    }
    template <class T>
    T* get() const {
        return reinterpret_cast<T*>(object_);
    }

private:
    PLib3MFBase* object_ = nullptr;
};

void check(LIB3MFRESULT result, const std::string& path, const char* what) {
    if (result != LIB3MF_OK) throw Error(path, std::string("3MF: ") + what + " failed (lib3mf error " + std::to_string(result) + ")");
}

// Millimetres per unit of a 3MF model.
double millimetres_per(DWORD unit) {
    switch (unit) {
    case MODELUNIT_MICROMETER: return 0.001;
    case MODELUNIT_MILLIMETER: return 1;
    case MODELUNIT_CENTIMETER: return 10;
    case MODELUNIT_INCH: return 25.4;
    case MODELUNIT_FOOT: return 304.8;
    case MODELUNIT_METER: return 1000;
    default: return 0;
    }
}

}  // namespace

void write_3mf(const Mesh& mesh, const std::string& path) {
    if (mesh.faces.empty()) throw Error(path, "3MF: the mesh has no triangles");
    Handle model, object, item, writer;
    check(lib3mf_createmodel(model.out<PLib3MFModel>()), path, "creating the model");
    check(lib3mf_model_setunit(model.get<PLib3MFModel>(), MODELUNIT_MILLIMETER), path, "setting millimetres");
    check(lib3mf_model_addmeshobject(model.get<PLib3MFModel>(), object.out<PLib3MFModelMeshObject>()), path, "adding the mesh");
    check(lib3mf_object_setnameutf8(object.get<PLib3MFModelObjectResource>(), "PicoScan scan"), path, "naming the mesh");
    std::vector<MODELMESHVERTEX> vertices(mesh.vertices.size());
    for (size_t v = 0; v < mesh.vertices.size(); ++v)
        for (int k = 0; k < 3; ++k) vertices[v].m_fPosition[k] = mesh.vertices[v][k];
    std::vector<MODELMESHTRIANGLE> triangles(mesh.faces.size());
    for (size_t f = 0; f < mesh.faces.size(); ++f)
        for (int k = 0; k < 3; ++k) triangles[f].m_nIndices[k] = static_cast<DWORD>(mesh.faces[f][k]);
    check(lib3mf_meshobject_setgeometry(object.get<PLib3MFModelMeshObject>(), vertices.data(), static_cast<DWORD>(vertices.size()),
                                        triangles.data(), static_cast<DWORD>(triangles.size())),
          path, "storing the triangles");
    check(lib3mf_model_addbuilditem(model.get<PLib3MFModel>(), object.get<PLib3MFModelObjectResource>(), nullptr,
                                    item.out<PLib3MFModelBuildItem>()),
          path, "adding the build item");
    check(lib3mf_model_querywriter(model.get<PLib3MFModel>(), "3mf", writer.out<PLib3MFModelWriter>()), path, "making the writer");
    ULONG64 size = 0;
    check(lib3mf_writer_getstreamsize(writer.get<PLib3MFModelWriter>(), &size), path, "sizing the file");
    std::string bytes(static_cast<size_t>(size), '\0');
    check(lib3mf_writer_writetobuffer(writer.get<PLib3MFModelWriter>(), reinterpret_cast<BYTE*>(bytes.data()), size), path,
          "writing");
    write_file_atomically(path, bytes);
}

Mesh read_3mf(const std::string& path) {
    std::string bytes = detail::read_whole_file(path);
    Handle model, reader, objects;
    check(lib3mf_createmodel(model.out<PLib3MFModel>()), path, "creating the model");
    check(lib3mf_model_queryreader(model.get<PLib3MFModel>(), "3mf", reader.out<PLib3MFModelReader>()), path, "making the reader");
    if (lib3mf_reader_readfrombuffer(reader.get<PLib3MFModelReader>(), reinterpret_cast<BYTE*>(bytes.data()), bytes.size()) !=
        LIB3MF_OK)
        throw Error(path, "is not a readable 3MF file");
    DWORD unit = 0;
    check(lib3mf_model_getunit(model.get<PLib3MFModel>(), &unit), path, "reading the unit");
    const double scale = millimetres_per(unit);
    if (scale <= 0) throw Error(path, "3MF: unknown unit " + std::to_string(unit));
    check(lib3mf_model_getmeshobjects(model.get<PLib3MFModel>(), objects.out<PLib3MFModelResourceIterator>()), path,
          "listing the meshes");
    Mesh out;
    BOOL more = false;
    while (lib3mf_resourceiterator_movenext(objects.get<PLib3MFModelResourceIterator>(), &more) == LIB3MF_OK && more) {
        Handle object;
        check(lib3mf_resourceiterator_getcurrent(objects.get<PLib3MFModelResourceIterator>(), object.out<PLib3MFModelResource>()),
              path, "reading a mesh");
        DWORD vertex_count = 0, triangle_count = 0;
        auto* mesh = object.get<PLib3MFModelMeshObject>();
        check(lib3mf_meshobject_getvertexcount(mesh, &vertex_count), path, "counting vertices");
        check(lib3mf_meshobject_gettrianglecount(mesh, &triangle_count), path, "counting triangles");
        std::vector<MODELMESHVERTEX> vertices(vertex_count);
        std::vector<MODELMESHTRIANGLE> triangles(triangle_count);
        if (vertex_count > 0) check(lib3mf_meshobject_getvertices(mesh, vertices.data(), vertex_count, nullptr), path, "reading vertices");
        if (triangle_count > 0)
            check(lib3mf_meshobject_gettriangleindices(mesh, triangles.data(), triangle_count, nullptr), path, "reading triangles");
        const int first = static_cast<int>(out.vertices.size());
        for (const MODELMESHVERTEX& v : vertices)
            out.vertices.emplace_back(static_cast<float>(v.m_fPosition[0] * scale), static_cast<float>(v.m_fPosition[1] * scale),
                                      static_cast<float>(v.m_fPosition[2] * scale));
        for (const MODELMESHTRIANGLE& t : triangles) {
            for (int k = 0; k < 3; ++k)
                if (t.m_nIndices[k] >= vertex_count) throw Error(path, "3MF: a triangle refers to a missing vertex");
            out.faces.emplace_back(first + static_cast<int>(t.m_nIndices[0]), first + static_cast<int>(t.m_nIndices[1]),
                                   first + static_cast<int>(t.m_nIndices[2]));
        }
    }
    if (out.faces.empty()) throw Error(path, "3MF: no mesh with triangles");
    return out;
}

}  // namespace picoscan
