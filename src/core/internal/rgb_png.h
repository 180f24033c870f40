// An 8-bit RGB PNG encoded in memory, row by row: the map's picture and the height map's.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

namespace octo_slice_mapper {

// `fill_row(y, rgb)` writes row y (0 at the top) as width x 3 bytes. False with the reason
// ("libpng could not start", "libpng failed") in `error`; `bytes` then holds nothing usable.
bool encodeRgbPng(int width, int height, const std::function<void(int, std::uint8_t*)>& fill_row, std::string* bytes,
                  std::string* error);

}  // namespace octo_slice_mapper
