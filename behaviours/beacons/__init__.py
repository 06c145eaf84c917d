"""BLE beacons: tracking iBeacon sightings and deciding arrival by RSSI."""
