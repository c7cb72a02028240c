#pragma once
// Every message type iapsim knows by name: the project's own (iapsim_msgs) and the standard ROS types it
// uses. Tools that handle messages of any type (recorder, echo, export, replay) look types up here.

#include <memory>
#include <string>
#include <vector>

#include "bridge/message.h"

namespace iapsim::bridge {

struct RegisteredType {
  TypeInfo info;
  std::shared_ptr<const SchemaSet> schema;
};

/// The type registered under `datatype`, or nullptr when iapsim does not know it.
const RegisteredType* FindType(const std::string& datatype);

/// Every registered type, sorted by name.
std::vector<const RegisteredType*> AllTypes();

}  // namespace iapsim::bridge
