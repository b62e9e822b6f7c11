#include "src/ros/common/master_watch.h"

#include <ros/connection_manager.h>
#include <ros/master.h>
#include <ros/network.h>
#include <ros/ros.h>
#include <ros/service_manager.h>
#include <ros/xmlrpc_manager.h>
#include <xmlrpcpp/XmlRpcClient.h>

#include <chrono>
#include <condition_variable>
#include <map>
#include <mutex>
#include <set>
#include <thread>
#include <vector>

#include "bsf_vpr/core/mutex.h"

namespace bsf_vpr {
namespace {

using XmlRpc::XmlRpcValue;

constexpr auto kPollPeriod = std::chrono::seconds(1);

// What identifies one run of the master: a restarted master has another process id and,
// started by roscore, another /run_id (the process id alone misses a master restarted in a
// container, where it is pid 1 each time).
struct MasterRun {
  int pid = 0;
  std::string run_id;
  bool operator==(const MasterRun& o) const { return pid == o.pid && run_id == o.run_id; }
};

// One call of the master's API without waiting for it; false if it does not answer or
// refuses.
bool CallMaster(const std::string& method, XmlRpcValue args, XmlRpcValue* payload) {
  XmlRpcValue result;
  return ros::master::execute(method, args, result, *payload, false);
}

XmlRpcValue Args(const std::string& a) {
  XmlRpcValue args;
  args[0] = ros::this_node::getName();
  args[1] = a;
  return args;
}

bool GetMasterRun(MasterRun* run) {
  XmlRpcValue args, pid, run_id;
  args[0] = ros::this_node::getName();
  if (!CallMaster("getPid", args, &pid) || pid.getType() != XmlRpcValue::TypeInt) return false;
  run->pid = static_cast<int>(pid);
  run->run_id.clear();
  if (CallMaster("getParam", Args("/run_id"), &run_id) &&
      run_id.getType() == XmlRpcValue::TypeString) {
    run->run_id = static_cast<std::string>(run_id);
  }
  return true;
}

// One call of this process's own slave API (its XML-RPC server), which lists what roscpp
// holds: publications, subscriptions and their connections.
bool CallSelf(const std::string& method, XmlRpcValue args, XmlRpcValue* payload) {
  std::string host;
  uint32_t port = 0;
  if (!ros::network::splitURI(ros::XMLRPCManager::instance()->getServerURI(), host, port)) {
    return false;
  }
  XmlRpc::XmlRpcClient client(host.c_str(), static_cast<int>(port), "/");
  XmlRpcValue result;
  if (!client.execute(method.c_str(), args, result) || client.isFault() ||
      result.getType() != XmlRpcValue::TypeArray || result.size() != 3 ||
      static_cast<int>(result[0]) != 1) {
    return false;
  }
  *payload = result[2];
  return true;
}

// [[topic, type], ...] of getPublications / getSubscriptions.
std::vector<std::pair<std::string, std::string>> TopicsOf(const std::string& method) {
  XmlRpcValue args, list;
  args[0] = ros::this_node::getName();
  std::vector<std::pair<std::string, std::string>> topics;
  if (!CallSelf(method, args, &list) || list.getType() != XmlRpcValue::TypeArray) return topics;
  for (int i = 0; i < list.size(); ++i) {
    topics.emplace_back(static_cast<std::string>(list[i][0]), static_cast<std::string>(list[i][1]));
  }
  return topics;
}

// The publishers (their XML-RPC URIs) each subscribed topic is connected to now.
std::map<std::string, std::set<std::string>> ConnectedPublishers() {
  XmlRpcValue args, info;
  args[0] = ros::this_node::getName();
  std::map<std::string, std::set<std::string>> connected;
  if (!CallSelf("getBusInfo", args, &info) || info.getType() != XmlRpcValue::TypeArray) {
    return connected;
  }
  for (int i = 0; i < info.size(); ++i) {
    XmlRpcValue& c = info[i];
    if (c.getType() == XmlRpcValue::TypeArray && c.size() >= 5 &&
        static_cast<std::string>(c[2]) == "i") {
      connected[static_cast<std::string>(c[4])].insert(static_cast<std::string>(c[1]));
    }
  }
  return connected;
}

}  // namespace

class MasterWatch::Process {
 public:
  Process() : thread_([this] { Run(); }) {}
  ~Process() {
    {
      MutexLock lock(&mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    thread_.join();
  }

  void Join(const std::string& ns) {
    MutexLock lock(&mutex_);
    namespaces_.insert(ns);
  }
  void Leave(const std::string& ns) {
    MutexLock lock(&mutex_);
    namespaces_.erase(namespaces_.find(ns));
    if (namespaces_.count(ns) == 0) parameters_.erase(ns);
  }

  // The process's watch while some node holds it.
  static std::shared_ptr<Process> Instance() {
    static Mutex instance_mutex;
    static std::weak_ptr<Process> instance;
    MutexLock lock(&instance_mutex);
    std::shared_ptr<Process> process = instance.lock();
    if (!process) {
      process = std::make_shared<Process>();
      instance = process;
    }
    return process;
  }

 private:
  void Run() {
    MasterRun known;
    bool have_known = false;
    MutexLock lock(&mutex_);
    while (!stop_) {
      lock.Unlock();
      MasterRun now;
      const bool up = ros::ok() && GetMasterRun(&now);
      if (up && have_known && !(now == known)) Reregister();
      if (up) {
        known = now;
        have_known = true;
        Remember();
      }
      lock.Lock();
      lock.AwaitFor(wake_, kPollPeriod, [this] {
        mutex_.AssertHeld();
        return stop_;
      });
    }
  }

  // What the master holds for this process, to put back on a restarted one: the joined
  // nodes' private parameters and the names of the process's services.
  void Remember() {
    std::set<std::string> namespaces;
    {
      MutexLock lock(&mutex_);
      namespaces.insert(namespaces_.begin(), namespaces_.end());
    }
    std::map<std::string, XmlRpcValue> parameters;
    for (const std::string& ns : namespaces) {
      XmlRpcValue value;
      if (CallMaster("getParam", Args(ns), &value)) parameters[ns] = value;
    }
    std::set<std::string> services;
    XmlRpcValue args, state;
    args[0] = ros::this_node::getName();
    if (CallMaster("getSystemState", args, &state) && state.getType() == XmlRpcValue::TypeArray &&
        state.size() == 3) {
      XmlRpcValue& list = state[2];
      for (int i = 0; i < list.size(); ++i) {
        for (int j = 0; j < list[i][1].size(); ++j) {
          if (static_cast<std::string>(list[i][1][j]) == ros::this_node::getName()) {
            services.insert(static_cast<std::string>(list[i][0]));
          }
        }
      }
    }
    MutexLock lock(&mutex_);
    for (auto& [ns, value] : parameters) {
      if (namespaces_.count(ns) != 0) parameters_[ns] = value;
    }
    services_ = services;
  }

  void Reregister() {
    const std::string me = ros::this_node::getName();
    const std::string my_api = ros::XMLRPCManager::instance()->getServerURI();
    std::map<std::string, XmlRpcValue> parameters;
    std::set<std::string> services;
    {
      MutexLock lock(&mutex_);
      parameters = parameters_;
      services = services_;
    }
    int n_parameters = 0, n_publishers = 0, n_subscribers = 0, n_services = 0, failed = 0;
    // Parameters first: a node the restart made respawn reads them at start.
    for (auto& [ns, value] : parameters) {
      XmlRpcValue args = Args(ns), payload;
      args[2] = value;
      (CallMaster("setParam", args, &payload) ? n_parameters : failed) += 1;
    }
    for (const auto& [topic, type] : TopicsOf("getPublications")) {
      XmlRpcValue args = Args(topic), payload;
      args[2] = type;
      args[3] = my_api;
      (CallMaster("registerPublisher", args, &payload) ? n_publishers : failed) += 1;
    }
    const auto connected = ConnectedPublishers();
    for (const auto& [topic, type] : TopicsOf("getSubscriptions")) {
      XmlRpcValue args = Args(topic), publishers;
      args[2] = type;
      args[3] = my_api;
      if (!CallMaster("registerSubscriber", args, &publishers) ||
          publishers.getType() != XmlRpcValue::TypeArray) {
        ++failed;
        continue;
      }
      ++n_subscribers;
      // Publishers that registered with the new master before this subscriber did were
      // never told about it: connect to them, keeping the connections already made (a
      // publisher not in the list would be dropped).
      auto it = connected.find(topic);
      std::set<std::string> all = it == connected.end() ? std::set<std::string>() : it->second;
      bool new_publisher = false;
      for (int i = 0; i < publishers.size(); ++i) {
        new_publisher |= all.insert(static_cast<std::string>(publishers[i])).second;
      }
      if (!new_publisher) continue;
      XmlRpcValue update = Args(topic), uris, ignored;
      uris.setSize(0);
      for (const std::string& uri : all) uris[uris.size()] = uri;
      update[2] = uris;
      CallSelf("publisherUpdate", update, &ignored);
    }
    const std::string service_api = "rosrpc://" + ros::network::getHost() + ":" +
                                    std::to_string(ros::ConnectionManager::instance()->getTCPPort());
    for (const std::string& service : services) {
      if (!ros::ServiceManager::instance()->lookupServicePublication(service)) continue;
      XmlRpcValue args = Args(service), payload;
      args[2] = service_api;
      args[3] = my_api;
      (CallMaster("registerService", args, &payload) ? n_services : failed) += 1;
    }
    const std::string refused = failed != 0 ? " (" + std::to_string(failed) + " refused)" : "";
    ROS_WARN("master restarted: re-registered %d publishers, %d subscribers, %d services and "
             "%d parameter namespaces of %s%s", n_publishers, n_subscribers, n_services,
             n_parameters, me.c_str(), refused.c_str());
  }

  Mutex mutex_;
  std::condition_variable wake_;
  bool stop_ GUARDED_BY(mutex_) = false;
  std::multiset<std::string> namespaces_ GUARDED_BY(mutex_);
  // Last seen on the master, per namespace; and this process's services, last seen there.
  std::map<std::string, XmlRpcValue> parameters_ GUARDED_BY(mutex_);
  std::set<std::string> services_ GUARDED_BY(mutex_);
  std::thread thread_;  // last: starts once the members above exist
};

MasterWatch::MasterWatch(const std::string& private_namespace)
    : process_(Process::Instance()), namespace_(private_namespace) {
  process_->Join(namespace_);
}

MasterWatch::~MasterWatch() { process_->Leave(namespace_); }

}  // namespace bsf_vpr
