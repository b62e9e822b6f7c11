// The generated messages and services: they build, serialise and keep their fields.
#include <bsf_vpr/Belief.h>
#include <bsf_vpr/Descriptor.h>
#include <bsf_vpr/ListReferenceSets.h>
#include <bsf_vpr/LoadReferenceSet.h>
#include <bsf_vpr/Match.h>
#include <bsf_vpr/QueryPlace.h>
#include <bsf_vpr/StartRecording.h>
#include <bsf_vpr/StopRecording.h>
#include <bsf_vpr/UnloadReferenceSet.h>
#include <gtest/gtest.h>
#include <ros/serialization.h>

#include <set>
#include <string>

#include "bsf_vpr/ros/names.h"

namespace bsf_vpr {
namespace {

template <typename M>
M RoundTrip(const M& in) {
  namespace ser = ros::serialization;
  const uint32_t size = ser::serializationLength(in);
  std::vector<uint8_t> buffer(size);
  ser::OStream out(buffer.data(), size);
  ser::serialize(out, in);
  M back;
  ser::IStream is(buffer.data(), size);
  ser::deserialize(is, back);
  return back;
}

TEST(Messages, BeliefRoundTripsThroughSerialisation) {
  Belief b;
  b.method = "bsf";
  b.gamma = 0.04;
  b.place_ids = {7, 3};
  b.posterior = {0.75f, 0.25f};
  b.set_names = {"summer", "winter"};
  b.set_min_distances = {0.5f, 0.6f};
  b.selected_sets = {"summer"};
  b.match = 7;
  b.confidence = 1.0986;
  b.accepted = true;
  const Belief back = RoundTrip(b);
  EXPECT_EQ(back.method, "bsf");
  EXPECT_EQ(back.place_ids, b.place_ids);
  EXPECT_EQ(back.posterior, b.posterior);
  EXPECT_EQ(back.selected_sets, b.selected_sets);
  EXPECT_EQ(back.match, 7);
  EXPECT_TRUE(back.accepted);
}

TEST(Messages, DescriptorAndMatchRoundTrip) {
  Descriptor d;
  d.descriptor_type = "netvlad_4096";
  d.data.assign(4096, 0.5f);
  EXPECT_EQ(RoundTrip(d).data.size(), 4096u);
  Match m;
  m.place_id = 12;
  m.reference_set = "night";
  m.has_pose = true;
  m.pose.position.x = 3.5;
  const Match mb = RoundTrip(m);
  EXPECT_EQ(mb.reference_set, "night");
  EXPECT_DOUBLE_EQ(mb.pose.position.x, 3.5);
}

TEST(Messages, ServicesCarrySuccessAndMessage) {
  LoadReferenceSet load;
  load.request.path = "winter.yaml";
  load.response.success = false;
  load.response.message = "no such file";
  EXPECT_EQ(RoundTrip(load.request).path, "winter.yaml");
  EXPECT_EQ(RoundTrip(load.response).message, "no such file");
  StopRecording stop;
  stop.response.num_descriptors = 42;
  EXPECT_EQ(RoundTrip(stop.response).num_descriptors, 42);
  QueryPlace query;
  query.response.belief.match = 5;
  EXPECT_EQ(RoundTrip(query.response).belief.match, 5);
  ListReferenceSets list;
  list.response.sets.resize(2);
  list.response.sets[1].name = "rain";
  EXPECT_EQ(RoundTrip(list.response).sets[1].name, "rain");
  EXPECT_TRUE((std::is_same<UnloadReferenceSet::Request::_name_type, std::string>::value));
  EXPECT_TRUE((std::is_same<StartRecording::Request::_condition_type, std::string>::value));
}

TEST(Names, AreDistinctAndRelative) {
  const std::vector<std::string> all = {
      names::kImageTopic, names::kExternalDescriptorTopic, names::kDescriptorTopic,
      names::kBeliefTopic, names::kMatchTopic, names::kBeliefMarkersTopic, names::kMatchImageTopic,
      names::kListReferenceSetsService, names::kLoadReferenceSetService,
      names::kUnloadReferenceSetService, names::kQueryPlaceService,
      names::kStartRecordingService, names::kStopRecordingService};
  EXPECT_EQ(std::set<std::string>(all.begin(), all.end()).size(), all.size());
  for (const std::string& n : all) EXPECT_NE(n.front(), '/') << n;
}

}  // namespace
}  // namespace bsf_vpr
