// A service served on a callback queue of the caller's (its own thread) rather than the
// node's: one that reads large files or waits for other nodes must not hold up the
// descriptors (the fusion node's and the shard's load_reference_set, the combiner's unload
// and query_place).
#pragma once

#include <ros/callback_queue.h>
#include <ros/node_handle.h>
#include <ros/service_server.h>

#include <string>

namespace bsf_vpr {

// Advertises `name` on `nh`, answered by object->handler on `queue` (null: the node's).
template <typename Service, typename Object>
ros::ServiceServer AdvertiseOnQueue(ros::NodeHandle& nh, const std::string& name,
                                    bool (Object::*handler)(typename Service::Request&,
                                                            typename Service::Response&),
                                    Object* object, ros::CallbackQueue* queue) {
  ros::AdvertiseServiceOptions options = ros::AdvertiseServiceOptions::create<Service>(
      name,
      [object, handler](typename Service::Request& req, typename Service::Response& res) {
        return (object->*handler)(req, res);
      },
      ros::VoidConstPtr(), queue);
  return nh.advertiseService(options);
}

}  // namespace bsf_vpr
