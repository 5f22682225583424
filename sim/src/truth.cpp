// The ground-truth message: the cart's true state, what the MCU drives, and counters.
#include "simulator.hpp"

namespace cart2d {

std::string Simulator::truth_json() const {
  const Cart& cart = rig_.cart();
  const ContactMonitor& contacts = rig_.contacts();
  const CpuMeter::Summary cpu = rig_.cpu().window();
  auto time_or_null = [](double t) { return t < 0 ? std::string("null") : json::number(t); };
  return json::Object()
      .add("type", "truth")
      .add("t", rig_.time_s())
      .add("x", cart.pose().x_m)
      .add("y", cart.pose().y_m)
      .add("theta", cart.pose().theta_rad)
      .add("v", cart.twist().v_mps)
      .add("omega", cart.twist().omega_radps)
      .add("wheel_l", cart.wheel_speed_l_radps())
      .add("wheel_r", cart.wheel_speed_r_radps())
      .add("slip_l", cart.slip_l_mps())
      .add("slip_r", cart.slip_r_mps())
      .add("caster", cart.caster_angle_rad())
      .add("duty_l", rig_.duties().left)
      .add("duty_r", rig_.duties().right)
      .add("current_l", cart.current_l_a())
      .add("current_r", cart.current_r_a())
      .add("switch_l", cart.switch_left())
      .add("switch_r", cart.switch_right())
      .add("enc_l", rig_.enc_dist_l_m())
      .add("enc_r", rig_.enc_dist_r_m())
      .add("collisions", static_cast<long long>(contacts.collisions()))
      .add("wall_contacts", static_cast<long long>(contacts.wall_contacts()))
      .add("box_contacts", static_cast<long long>(contacts.box_contacts()))
      .add("in_collision", contacts.in_collision())
      .add("in_wall_contact", contacts.in_wall_contact())
      .add("in_box_contact", contacts.in_box_contact())
      .add("boxes", static_cast<unsigned long long>(rig_.world().count(BoxKind::kBox)))
      .add_raw("first_collision_t", time_or_null(contacts.first_collision_t()))
      .add_raw("first_wall_contact_t", time_or_null(contacts.first_wall_contact_t()))
      .add_raw("cpu", json::Object()
                          .add("mean", cpu.mean)
                          .add("max", cpu.max)
                          .add("ticks", static_cast<unsigned long long>(cpu.ticks))
                          .str())
      .add("rtf", pacer_.rtf())
      .add("mcu", rig_.mcu().state_name())
      .str();
}

}  // namespace cart2d
