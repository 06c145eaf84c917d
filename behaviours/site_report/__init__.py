"""Every robot on its site's fleet server: its status report and the staff's orders.

What it reports each ``fleet.period_s``, and the staff's orders (e-stop, resume, maintenance)
it takes from the answer.

A shared capability, named by no robot: the daemon runs it for any profile when ``fleet.url``
is set (unless the profile's own link reports all of it, as the laundry data exchange does);
each profile says where it is and what job it does through ``Profile.site_facts``.
"""
