// pf_draco_decode (draco_decode.h) over Draco's decoder. C++ only because the library is:
// no exception crosses the interface (Draco reports failures by status, and an allocation
// failure of its own is caught here).
#include "draco_decode.h"

#include <draco/compression/decode.h>

#include <cstdio>
#include <cstdlib>
#include <new>

namespace {

int fail(char *message, size_t message_size, const char *text)
{
    std::snprintf(message, message_size, "%s", text);
    return -1;
}

void release(pf_draco_attribute *attributes, uint32_t count, pf_draco_mesh *mesh)
{
    for (uint32_t a = 0; a < count; a++) {
        std::free(attributes[a].values);
        attributes[a].values = nullptr;
    }
    std::free(mesh->indices);
    mesh->indices = nullptr;
}

int decode(const unsigned char *data, size_t size, pf_draco_attribute *attributes,
           uint32_t attribute_count, pf_draco_mesh *mesh, char *message, size_t message_size)
{
    draco::DecoderBuffer buffer;
    buffer.Init(reinterpret_cast<const char *>(data), size);
    draco::Decoder decoder;
    auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
    if (!decoded.ok()) {
        std::snprintf(message, message_size, "not a Draco mesh: %s",
                      decoded.status().error_msg());
        return -1;
    }
    const std::unique_ptr<draco::Mesh> &decoded_mesh = decoded.value();
    const uint32_t points = decoded_mesh->num_points();
    const uint32_t faces = decoded_mesh->num_faces();
    if (faces > UINT32_MAX / 3)
        return fail(message, message_size, "too many faces");
    mesh->point_count = points;
    mesh->index_count = 3 * faces;
    size_t index_bytes = (faces > 0 ? 3 * (size_t)faces : 1) * sizeof(uint32_t);
    mesh->indices = static_cast<uint32_t *>(std::malloc(index_bytes));
    if (!mesh->indices)
        return fail(message, message_size, "out of memory");
    for (uint32_t f = 0; f < faces; f++) {
        const draco::Mesh::Face &face = decoded_mesh->face(draco::FaceIndex(f));
        for (int c = 0; c < 3; c++)
            mesh->indices[3 * f + c] = face[c].value();
    }
    for (uint32_t a = 0; a < attribute_count; a++) {
        pf_draco_attribute *wanted = &attributes[a];
        const draco::PointAttribute *attribute =
            decoded_mesh->GetAttributeByUniqueId(wanted->unique_id);
        if (!attribute) {
            std::snprintf(message, message_size, "attribute %u is not in the stream",
                          wanted->unique_id);
            return -1;
        }
        if (wanted->components == 0 || wanted->components > 16 ||
            attribute->num_components() < wanted->components) {
            std::snprintf(message, message_size, "attribute %u has %d components, %u expected",
                          wanted->unique_id, attribute->num_components(), wanted->components);
            return -1;
        }
        wanted->values = static_cast<double *>(
            std::malloc((points > 0 ? (size_t)points : 1) * wanted->components * sizeof(double)));
        if (!wanted->values)
            return fail(message, message_size, "out of memory");
        double value[16];
        for (uint32_t p = 0; p < points; p++) {
            if (!attribute->ConvertValue<double>(attribute->mapped_index(draco::PointIndex(p)),
                                                 static_cast<int8_t>(wanted->components), value)) {
                std::snprintf(message, message_size, "attribute %u: value %u unreadable",
                              wanted->unique_id, p);
                return -1;
            }
            for (uint32_t c = 0; c < wanted->components; c++)
                wanted->values[(size_t)p * wanted->components + c] = value[c];
        }
    }
    return 0;
}

} // namespace

extern "C" int pf_draco_decode(const unsigned char *data, size_t size,
                               pf_draco_attribute *attributes, uint32_t attribute_count,
                               pf_draco_mesh *mesh, char *message, size_t message_size)
{
    mesh->point_count = mesh->index_count = 0;
    mesh->indices = nullptr;
    for (uint32_t a = 0; a < attribute_count; a++)
        attributes[a].values = nullptr;
    int result;
    try {
        result = decode(data, size, attributes, attribute_count, mesh, message, message_size);
    } catch (const std::bad_alloc &) {
        result = fail(message, message_size, "out of memory");
    }
    if (result != 0)
        release(attributes, attribute_count, mesh);
    return result;
}
