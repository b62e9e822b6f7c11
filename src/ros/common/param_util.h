// Reading the parameters of the bsf_vpr nodes from the options tables (core options.h).
#pragma once

#include <ros/node_handle.h>
#include <xmlrpcpp/XmlRpcValue.h>

#include <optional>
#include <string>
#include <vector>

#include "bsf_vpr/core/options.h"

namespace bsf_vpr {

// The parameters of one namespace, as one struct (read once from the parameter server, or
// made by a test without a master), with the keys that were read tracked: a key that no
// table read is refused by RefuseUnread().
class RosParamSource : public OptionSource {
 public:
  // `params` is a struct of the parameters under `ns` (an invalid value: none).
  RosParamSource(XmlRpc::XmlRpcValue params, std::string ns);
  // The private parameters of a node.
  static RosParamSource FromNodeHandle(const ros::NodeHandle& pnh);

  std::optional<OptionValue> Get(const std::string& name, OptionType type) override;
  std::string Describe(const std::string& name) const override { return ns_ + "/" + name; }
  // The raw value of a parameter read by code of its own (an external option); marks it read.
  std::optional<XmlRpc::XmlRpcValue> GetRaw(const std::string& name);
  bool Has(const std::string& name) const;

  // Throws std::invalid_argument listing the parameters that nothing read (a misspelt
  // parameter would otherwise be silently ignored).
  void RefuseUnread() const;

 private:
  XmlRpc::XmlRpcValue params_;
  std::string ns_;
  std::vector<std::string> read_;
};

// Reads every option of `table` from `source` into a default S and returns it. Throws
// std::invalid_argument naming the parameter.
template <typename S>
S LoadOptions(const OptionTable<S>& table, RosParamSource& source) {
  S options;
  table.Apply(source, &options);
  return options;
}

// What a node with a queue of descriptors and diagnostics reads (QueueParamsTable()).
struct QueueParams {
  int queue_size = 100;            // descriptors buffered before the oldest are dropped
  double diagnostic_period = 1.0;  // seconds (diagnostic_updater reads it too)
};
const OptionTable<QueueParams>& QueueParamsTable();

}  // namespace bsf_vpr
