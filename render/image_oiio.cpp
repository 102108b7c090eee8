// image_oiio.cpp - image.h implemented with OpenImageIO: the only file of
// the project that includes it. No exception leaves this file: every entry
// point catches and turns failures into a logged rad_status.
#include "image.h"

#include <OpenImageIO/imageio.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <memory>
#include <new>
#include <string>
#include <vector>

extern "C" {
#include "rad_fs.h"
#include "rad_log.h"
}

namespace {

const char *const kSoftware = "radiosity render";

bool ends_with_nocase(const char *s, const char *suffix)
{
    size_t n = std::strlen(s), m = std::strlen(suffix);
    if (n < m) return false;
    for (size_t i = 0; i < m; i++) {
        char c = s[n - m + i];
        if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
        if (c != suffix[i]) return false;
    }
    return true;
}

// Display-encoded [0, 1] floats -> 8-bit, round to nearest, clamped.
std::vector<unsigned char> quantize_8bit(const float *rgb, size_t count)
{
    std::vector<unsigned char> bytes(count);
    for (size_t i = 0; i < count; i++) {
        float v = rgb[i];
        v = v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f; // NaN -> 0
        bytes[i] = static_cast<unsigned char>(std::lround(v * 255.0f));
    }
    return bytes;
}

// Reads `temp` back. OpenImageIO's PNG writer does not report a failed
// write: on a full disk it gave a 0-byte file and success, which would then
// have been renamed over a good image. So a written file is trusted only
// once it decodes to the size written and, for PNG, to the very bytes
// written (`png_bytes`; NULL for EXR, whose decoding is checked).
rad_status verify_temp(const char *path, const char *temp, int width, int height, int channels,
                       const unsigned char *png_bytes)
{
    using namespace OIIO;
    std::unique_ptr<ImageInput> in = ImageInput::open(temp);
    if (!in) {
        rad_error("%s: the written file does not read back (disk full?): %s", path, OIIO::geterror().c_str());
        return RAD_ERR_IO;
    }
    const ImageSpec &spec = in->spec();
    bool ok = spec.width == width && spec.height == height && spec.nchannels == channels;
    const size_t row_values = static_cast<size_t>(channels) * static_cast<size_t>(width);
    std::vector<unsigned char> row(row_values * (png_bytes ? 1 : 2));
    for (int y = 0; ok && y < height; y++) {
        ok = in->read_scanline(y, 0, png_bytes ? TypeDesc::UINT8 : TypeDesc::HALF, row.data());
        if (ok && png_bytes) ok = std::memcmp(row.data(), png_bytes + row_values * static_cast<size_t>(y), row_values) == 0;
    }
    std::string why = ok ? std::string() : in->geterror();
    in->close();
    if (!ok) {
        rad_error("%s: the written file does not read back as written (disk full?)%s%s", path, why.empty() ? "" : ": ",
                  why.c_str());
        return RAD_ERR_IO;
    }
    return RAD_OK;
}

// Opens, writes, closes and verifies `temp`; returns RAD_OK or a logged status.
rad_status write_temp(const char *path, const char *temp, render_image_format format, const float *values, int width,
                      int height, int channels, const render_image_attr *attrs, size_t attr_count)
{
    using namespace OIIO;
    const bool png = format == RENDER_IMAGE_PNG;
    std::unique_ptr<ImageOutput> out = ImageOutput::create(png ? "png" : "openexr");
    if (!out) {
        rad_error("%s: this OpenImageIO cannot write %s: %s", path, png ? "PNG" : "OpenEXR", OIIO::geterror().c_str());
        return RAD_ERR_UNSUPPORTED;
    }
    ImageSpec spec(width, height, channels, png ? TypeDesc::UINT8 : TypeDesc::HALF);
    if (channels == 1) spec.channelnames.assign(1, "Y"); // EXR's name for a grey (luminance) channel
    spec.attribute("Software", kSoftware);
    spec.attribute("DateTime", RENDER_IMAGE_DATETIME);
    spec.attribute("oiio:ColorSpace", png ? "sRGB" : "Linear");
    if (!png) spec.attribute("compression", "zip");
    for (size_t i = 0; i < attr_count; i++) spec.attribute(attrs[i].name, attrs[i].value);
    if (!out->open(temp, spec)) {
        rad_error("%s: cannot write: %s", path, out->geterror().c_str());
        return RAD_ERR_IO;
    }
    const size_t count = static_cast<size_t>(channels) * static_cast<size_t>(width) * static_cast<size_t>(height);
    bool ok;
    std::vector<unsigned char> bytes;
    if (png) {
        bytes = quantize_8bit(values, count);
        ok = out->write_image(TypeDesc::UINT8, bytes.data());
    } else {
        ok = out->write_image(TypeDesc::FLOAT, values);
    }
    std::string why = ok ? std::string() : out->geterror();
    if (!out->close() && ok) {
        ok = false;
        why = out->geterror();
    }
    if (!ok) {
        rad_error("%s: cannot write: %s", path, why.empty() ? "unknown OpenImageIO error" : why.c_str());
        return RAD_ERR_IO;
    }
    if (std::strcmp(path, temp) == 0) return RAD_OK; // a device written in place (rad_fs.h): nothing to read back
    return verify_temp(path, temp, width, height, channels, png ? bytes.data() : nullptr);
}

} // namespace

extern "C" render_image_format render_image_format_of(const char *path)
{
    if (ends_with_nocase(path, ".png")) return RENDER_IMAGE_PNG;
    if (ends_with_nocase(path, ".exr")) return RENDER_IMAGE_EXR;
    return RENDER_IMAGE_UNKNOWN;
}

extern "C" rad_status render_image_write(const char *path, const float *values, int width, int height, int channels,
                                         const render_image_attr *attrs, size_t attr_count)
{
    rad_status status = RAD_OK;
    char temp[4096];
    bool temp_named = false;
    render_image_format format = render_image_format_of(path);
    if (format == RENDER_IMAGE_UNKNOWN) {
        rad_error("%s: unknown image type (the name must end in .png or .exr)", path);
        status = RAD_ERR_USAGE;
        goto done;
    }
    if (width < 1 || height < 1) {
        rad_error("%s: image size %dx%d is empty", path, width, height);
        status = RAD_ERR_INVALID;
        goto done;
    }
    if (channels != 1 && channels != 3) {
        rad_error("%s: %d channels (expected 1 or 3)", path, channels);
        status = RAD_ERR_INVALID;
        goto done;
    }
    status = rad_fs_temp_create(path, temp, sizeof temp);
    if (status != RAD_OK) goto done;
    temp_named = true;
    try {
        status = write_temp(path, temp, format, values, width, height, channels, attrs, attr_count);
    } catch (const std::bad_alloc &) {
        rad_error("%s: out of memory writing the image", path);
        status = RAD_ERR_NOMEM;
    } catch (const std::exception &e) {
        rad_error("%s: cannot write: %s", path, e.what());
        status = RAD_ERR_IO;
    }
    if (status != RAD_OK) goto done;
    status = rad_fs_commit(temp, path);
    temp_named = false; /* commit removes the temporary itself on failure */
done:
    if (status != RAD_OK && temp_named) rad_fs_discard(temp);
    return status;
}

namespace {

rad_status read_impl(const char *path, float **out_values, int *out_width, int *out_height, int *out_channels)
{
    using namespace OIIO;
    std::unique_ptr<ImageInput> in = ImageInput::open(path);
    if (!in) {
        rad_error("%s: cannot read: %s", path, OIIO::geterror().c_str());
        return RAD_ERR_IO;
    }
    const ImageSpec &spec = in->spec();
    if (spec.nchannels < 1 || spec.width < 1 || spec.height < 1) {
        rad_error("%s: not an image (%d channels, %dx%d)", path, spec.nchannels, spec.width, spec.height);
        in->close();
        return RAD_ERR_FORMAT;
    }
    const int channels = spec.nchannels < 3 ? 1 : 3;
    const size_t count = static_cast<size_t>(channels) * static_cast<size_t>(spec.width) *
                         static_cast<size_t>(spec.height);
    float *values = static_cast<float *>(std::malloc(count * sizeof *values));
    if (!values) {
        rad_error("%s: out of memory reading the image", path);
        in->close();
        return RAD_ERR_NOMEM;
    }
    if (!in->read_image(0, 0, 0, channels, TypeDesc::FLOAT, values)) {
        rad_error("%s: cannot read pixels: %s", path, in->geterror().c_str());
        std::free(values);
        in->close();
        return RAD_ERR_IO;
    }
    *out_width = spec.width;
    *out_height = spec.height;
    *out_channels = channels;
    *out_values = values;
    in->close();
    return RAD_OK;
}

} // namespace

extern "C" rad_status render_image_read(const char *path, float **out_values, int *out_width, int *out_height,
                                        int *out_channels)
{
    try {
        return read_impl(path, out_values, out_width, out_height, out_channels);
    } catch (const std::exception &e) {
        rad_error("%s: cannot read: %s", path, e.what());
        return RAD_ERR_IO;
    }
}

extern "C" rad_status render_image_read_attr(const char *path, const char *name, char *out, size_t size)
{
    try {
        std::unique_ptr<OIIO::ImageInput> in = OIIO::ImageInput::open(path);
        if (!in) {
            rad_error("%s: cannot read: %s", path, OIIO::geterror().c_str());
            return RAD_ERR_IO;
        }
        const OIIO::ParamValue *p = in->spec().find_attribute(name, OIIO::TypeDesc::STRING);
        if (!p) {
            rad_error("%s: no attribute '%s'", path, name);
            return RAD_ERR_INVALID;
        }
        std::string value = p->get_string();
        if (size > 0) {
            std::strncpy(out, value.c_str(), size - 1);
            out[size - 1] = 0;
        }
        return RAD_OK;
    } catch (const std::exception &e) {
        rad_error("%s: cannot read: %s", path, e.what());
        return RAD_ERR_IO;
    }
}

namespace {

void copy_truncated(const std::string &value, char *out, size_t size)
{
    if (size > 0) {
        std::strncpy(out, value.c_str(), size - 1);
        out[size - 1] = 0;
    }
}

} // namespace

extern "C" rad_status render_image_read_layout(const char *path, char *names, size_t names_size, char *type,
                                               size_t type_size)
{
    try {
        std::unique_ptr<OIIO::ImageInput> in = OIIO::ImageInput::open(path);
        if (!in) {
            rad_error("%s: cannot read: %s", path, OIIO::geterror().c_str());
            return RAD_ERR_IO;
        }
        const OIIO::ImageSpec &spec = in->spec();
        std::string joined;
        for (int c = 0; c < spec.nchannels; c++) {
            if (c) joined += ',';
            joined += spec.channel_name(c);
        }
        copy_truncated(joined, names, names_size);
        copy_truncated(spec.format.c_str(), type, type_size);
        in->close();
        return RAD_OK;
    } catch (const std::exception &e) {
        rad_error("%s: cannot read: %s", path, e.what());
        return RAD_ERR_IO;
    }
}
