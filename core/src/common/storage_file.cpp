#include "common/storage_file.h"

#include "picoscan/error.h"

#include <filesystem>
#include <fstream>

namespace picoscan::detail {

namespace {

constexpr std::uintmax_t kLargestStorageFile = 64u << 20;  // calibration and manifests are small

std::string trimmed(const std::string& text) {
    const size_t first = text.find_first_not_of(" \t\r\n");
    if (first == std::string::npos) return "";
    return text.substr(first, text.find_last_not_of(" \t\r\n") - first + 1);
}

}  // namespace

std::string read_text_file(const std::string& path, const std::string& what) {
    std::error_code error;
    if (!std::filesystem::is_regular_file(path, error)) throw Error(path, what + " not found");
    if (std::filesystem::file_size(path, error) > kLargestStorageFile) throw Error(path, what + " is larger than 64 MB");
    std::ifstream stream(path, std::ios::binary);
    std::string text((std::istreambuf_iterator<char>(stream)), std::istreambuf_iterator<char>());
    if (stream.bad()) throw Error(path, "cannot read the " + what);
    if (trimmed(text).empty()) throw Error(path, what + " is empty");
    // OpenCV's YAML parser can loop forever on control bytes; these files are plain ASCII.
    for (size_t offset = 0; offset < text.size(); ++offset) {
        const unsigned char byte = static_cast<unsigned char>(text[offset]);
        if ((byte < 0x20 && byte != '\n' && byte != '\r' && byte != '\t') || byte > 0x7e)
            throw Error(path, what + " is not a plain ASCII text file (byte " + std::to_string(int(byte)) +
                                  " at offset " + std::to_string(offset) + ")");
    }
    return text;
}

cv::FileStorage open_storage_file(const std::string& path, const std::string& what, StorageFormats formats) {
    std::string text = read_text_file(path, what);
    for (size_t line = text.find('\n'); line != std::string::npos; line = text.find('\n', line + 1))
        if (line + 1 < text.size() && text[line + 1] == '%')
            throw Error(path, what + ": a '%' directive is only allowed on the first line");
    const std::string content = trimmed(text);
    const char first = content.front();
    if (formats == StorageFormats::JsonOnly && first != '{') throw Error(path, what + " must be a JSON object");
    if (first == '<') {
        // OpenCV's XML parser reads past the end of a truncated tag; a complete file ends
        // with its root element closed.
        const std::string closing = "</opencv_storage>";
        if (content.size() < closing.size() || content.compare(content.size() - closing.size(), closing.size(), closing) != 0)
            throw Error(path, what + " is not a complete OpenCV XML file (no closing </opencv_storage>)");
    } else if (first != '{' && content.rfind("%YAML", 0) != 0) {
        text = "%YAML:1.0\n" + text;
    }

    const std::string format_name = first == '{' ? "JSON" : first == '<' ? "XML" : "YAML";
    cv::FileStorage storage;
    try {
        const int format = first == '{' ? cv::FileStorage::FORMAT_JSON
                         : first == '<' ? cv::FileStorage::FORMAT_XML : cv::FileStorage::FORMAT_YAML;
        if (!storage.open(text, cv::FileStorage::READ | cv::FileStorage::MEMORY | format))
            throw Error(path, "cannot parse the " + what + " as " + format_name);
    } catch (const Error&) {
        throw;
    } catch (const cv::Exception& failure) {
        throw Error(path, "cannot parse the " + what + " as " + format_name + " (" + failure.err + ")");
    } catch (const std::exception& failure) {
        throw Error(path, "cannot parse the " + what + " as " + format_name + " (" + failure.what() + ")");
    }
    return storage;
}

}  // namespace picoscan::detail
