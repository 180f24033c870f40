// parameter_doc: prints the parameter reference (doc/parameters.md) generated from the option
// tables.   parameter_doc > doc/parameters.md
#include <iostream>

#include "ros/parameter_reference.h"

int main() {
  std::cout << octo_slice_mapper::ros_adapter::parameterReference();
  return 0;
}
