// The parameter reference (doc/parameters.md) as generated from the option tables: every mapper
// option (node parameter and octo_slice_map flag) and every node option, with type, unit,
// default, whether it can change while the node runs, and what it does.
#pragma once

#include <string>

namespace octo_slice_mapper {
namespace ros_adapter {

std::string parameterReference();

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
