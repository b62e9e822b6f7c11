#include "src/ros/common/param_util.h"

#include <ros/param.h>
#include <xmlrpcpp/XmlRpcException.h>

#include <algorithm>
#include <stdexcept>

namespace bsf_vpr {
namespace {

OptionValue FromXmlRpc(XmlRpc::XmlRpcValue& v, const std::string& shown) {
  switch (v.getType()) {
    case XmlRpc::XmlRpcValue::TypeBoolean:
      return static_cast<bool>(v);
    case XmlRpc::XmlRpcValue::TypeInt:
      return static_cast<long long>(static_cast<int>(v));
    case XmlRpc::XmlRpcValue::TypeDouble:
      return static_cast<double>(v);
    case XmlRpc::XmlRpcValue::TypeString:
      return static_cast<std::string>(v);
    case XmlRpc::XmlRpcValue::TypeArray: {
      std::vector<double> out;
      for (int i = 0; i < v.size(); ++i) {
        if (v[i].getType() == XmlRpc::XmlRpcValue::TypeInt) {
          out.push_back(static_cast<int>(v[i]));
        } else if (v[i].getType() == XmlRpc::XmlRpcValue::TypeDouble) {
          out.push_back(static_cast<double>(v[i]));
        } else {
          throw std::invalid_argument("parameter '" + shown + "' must be a list of numbers");
        }
      }
      return out;
    }
    default:
      throw std::invalid_argument("parameter '" + shown + "' has the wrong type");
  }
}

}  // namespace

RosParamSource::RosParamSource(XmlRpc::XmlRpcValue params, std::string ns)
    : params_(std::move(params)), ns_(std::move(ns)) {
  if (params_.valid() && params_.getType() != XmlRpc::XmlRpcValue::TypeStruct) {
    throw std::invalid_argument("the parameters under " + ns_ + " are not a mapping");
  }
}

RosParamSource RosParamSource::FromNodeHandle(const ros::NodeHandle& pnh) {
  XmlRpc::XmlRpcValue params;
  if (!ros::param::get(pnh.getNamespace(), params)) params = XmlRpc::XmlRpcValue();
  // A namespace that holds a single value, not parameters, is refused by the constructor.
  return RosParamSource(params, pnh.getNamespace());
}

bool RosParamSource::Has(const std::string& name) const {
  return params_.valid() && params_.hasMember(name);
}

std::optional<XmlRpc::XmlRpcValue> RosParamSource::GetRaw(const std::string& name) {
  if (!Has(name)) return std::nullopt;
  if (std::find(read_.begin(), read_.end(), name) == read_.end()) read_.push_back(name);
  return params_[name];
}

std::optional<OptionValue> RosParamSource::Get(const std::string& name, OptionType type) {
  std::optional<XmlRpc::XmlRpcValue> raw = GetRaw(name);
  if (!raw) return std::nullopt;
  const std::string shown = Describe(name);
  try {
    return ConvertOptionValue(FromXmlRpc(*raw, shown), type, "parameter '" + shown + "'");
  } catch (const XmlRpc::XmlRpcException& e) {
    throw std::invalid_argument("parameter '" + shown + "': " + e.getMessage());
  }
}

void RosParamSource::RefuseUnread() const {
  if (!params_.valid()) return;
  std::string unknown;
  // XmlRpcValue's iteration is not const; a copy shares nothing we change.
  XmlRpc::XmlRpcValue params = params_;
  for (auto it = params.begin(); it != params.end(); ++it) {
    if (std::find(read_.begin(), read_.end(), it->first) == read_.end()) {
      unknown += (unknown.empty() ? "" : ", ") + ns_ + "/" + it->first;
    }
  }
  if (!unknown.empty()) {
    throw std::invalid_argument("unknown parameter(s): " + unknown +
                                " (config/fusion.yaml and config/ingest.yaml list every one)");
  }
}

const OptionTable<QueueParams>& QueueParamsTable() {
  static const OptionTable<QueueParams> kTable =
      OptionTable<QueueParams>()
          .Add(
              "queue_size", [](auto& p) -> auto& { return p.queue_size; },
              "descriptors buffered before the oldest are dropped", "messages", AtLeast(1))
          .Add(
              "diagnostic_period", [](auto& p) -> auto& { return p.diagnostic_period; },
              "time between diagnostics updates (read by diagnostic_updater)", "s", Above(0));
  return kTable;
}

}  // namespace bsf_vpr
