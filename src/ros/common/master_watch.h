// Keeps this process's ROS nodes known to a ROS master that restarts. roscpp registers a
// publisher, a subscriber or a service with the master once, when it is made; a roscore
// killed and started again knows none of them: connections made before go on, but
// `rosnode list` lacks the node, its services cannot be found and a new publisher or
// subscriber never reaches it. MasterWatch notices the restart (the master's process id or
// its /run_id changed) and registers again everything the process holds: its publishers,
// its subscribers (connecting to the publishers the new master knows, keeping the
// connections it has), its services, and the private parameters of each node that joined
// (the values last seen on the old master). Nothing in the nodes is touched: their loaded
// sets, recordings and beliefs carry on.
//
// One watch per process (a nodelet manager's nodelets share it): the first MasterWatch
// starts it, the last one destroyed stops it. bsf_vpr's nodes and nodelets join it in
// node_runner.h.
#pragma once

#include <memory>
#include <string>

namespace bsf_vpr {

class MasterWatch {
 public:
  // Joins the process's watch; the parameters below `private_namespace` (the node's
  // private namespace) are put back on a restarted master. Needs ros::init.
  explicit MasterWatch(const std::string& private_namespace);
  ~MasterWatch();
  MasterWatch(const MasterWatch&) = delete;
  MasterWatch& operator=(const MasterWatch&) = delete;

  // The process-wide watch (a thread polling the master every second).
  class Process;

 private:
  std::shared_ptr<Process> process_;
  std::string namespace_;
};

}  // namespace bsf_vpr
