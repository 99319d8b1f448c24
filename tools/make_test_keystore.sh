#!/usr/bin/env bash
# A TEST keystore for DDS Security, made with openssl only, in the layout of ROS 2's SROS2
# (`ros2 security create_keystore` + `create_enclave`), so mlmap and a ROS 2 Jazzy ground
# station can use the same folder (ROS_SECURITY_KEYSTORE):
#
#   <keystore>/public/ca.cert.pem                    the test CA (identity and permissions CA)
#   <keystore>/public/{identity_ca,permissions_ca}.cert.pem -> ca.cert.pem
#   <keystore>/private/ca.key.pem                    (and the links, as SROS2)
#   <keystore>/enclaves/governance.{xml,p7s}         one governance for every enclave
#   <keystore>/enclaves/<enclave>/{identity_ca.cert.pem, permissions_ca.cert.pem, governance.p7s}
#                                                    links into public/ and enclaves/, as SROS2
#   <keystore>/enclaves/<enclave>/{cert.pem, key.pem, permissions.xml, permissions.p7s}
#
# Enclaves (ROS 2 topic names, `rt/...`; `*` also matches a namespace):
#   /mlmap/node             the onboard node: reads sensor topics, publishes the map layers and tf
#   /mlmap/sensor           a sensor driver / simulator: publishes clouds, depth images and poses
#   /ground/monitor         a ground station: reads everything, may publish anything and call
#                           any service (save_map, clear_map, parameters)
#   /ground/viewer_readonly reads the map layers, tf and status and may call the services that
#                           read parameters; publishing clouds, images or poses, and calling
#                           save_map, clear_map or set_parameters, is denied
#   /fleet/uav1, /fleet/uav2 two vehicles of a fleet: each publishes under its own name only
#                           (rt/uavN/*: its submaps rt/uavN/mlmap/submaps, its layers), tf,
#                           and reads everything (the others' submaps as priors, its sensors)
#   /fleet/merger           mlmap_fleet: reads every vehicle's submaps (rt/*/mlmap/submaps),
#                           publishes the merged map (rt/*mlmap/fleet/*)
#   /stranger               a complete, self-consistent identity from a DIFFERENT CA
#                           (<keystore>/private/stranger_ca.key.pem): nobody above trusts it
# Governance: authenticated participants only, join access control, and rtps, discovery,
# liveliness, metadata and data protection ENCRYPT (AES-GCM-GMAC) on every topic.
# With --protection payload: rtps and metadata protection NONE, so each sample is encrypted once
# (data ENCRYPT) instead of three times (payload, submessage, message); discovery and liveliness
# stay ENCRYPT. Map data is as hidden; RTPS headers (GUIDs, sequence numbers) are not.
# With --protection link: what crosses the radio link (map layers, tf, poses, status) as with
# `payload`, but the raw sensor streams (rt/*cloud, rt/*image*, rt/*camera_info), which go from
# the driver to the node on the vehicle's computer, are neither encrypted nor signed (metadata
# and data NONE): only authenticated peers with the permission discover, read or write them, but
# a forged packet sent to the node's port would not be detected. With --protection link-signed
# they are signed (metadata SIGN): no forged or altered samples, for sensors on another computer
# of the vehicle's network; it costs more (README, Cost of encryption).
#
#   tools/make_test_keystore.sh <keystore dir> [--days N] [--protection full|payload|link|link-signed]
#
# Idempotent: what exists is kept (keys are never replaced, so running it again changes nothing),
# what is missing is made; each file is listed as "made" or "kept". The XML is signed as SROS2
# does (S/MIME, detached, text, SHA-256). Test keys only: never commit them, never fly them.
set -euo pipefail
usage() { echo "usage: $0 <keystore dir> [--days N] [--protection full|payload|link|link-signed]" >&2; exit 64; }
[ $# -ge 1 ] || usage
root=$1; shift
days=3650 protection=full
while [ $# -gt 0 ]; do
  case $1 in
    --days) days=$2; shift 2 ;;
    --protection) protection=$2; shift 2 ;;
    *) usage ;;
  esac
done
case $protection in
  full) message=ENCRYPT ;;
  payload|link|link-signed) message=NONE ;;
  *) usage ;;
esac
# topic_rule <expression> <metadata protection> <data protection>: read and write access control on.
topic_rule() {
  cat <<EOF
        <topic_rule>
          <topic_expression>$1</topic_expression>
          <enable_discovery_protection>true</enable_discovery_protection>
          <enable_liveliness_protection>true</enable_liveliness_protection>
          <enable_read_access_control>true</enable_read_access_control>
          <enable_write_access_control>true</enable_write_access_control>
          <metadata_protection_kind>$2</metadata_protection_kind>
          <data_protection_kind>$3</data_protection_kind>
        </topic_rule>
EOF
}
# The first rule whose expression matches a topic decides.
topic_rules=""
case $protection in link) onboard=NONE ;; link-signed) onboard=SIGN ;; *) onboard="" ;; esac
if [ -n "$onboard" ]; then
  for topic in 'rt/*cloud' 'rt/*image*' 'rt/*camera_info'; do
    topic_rules+=$(topic_rule "$topic" "$onboard" NONE)$'\n'
  done
fi
topic_rules+=$(topic_rule '*' "$message" ENCRYPT)
command -v openssl >/dev/null || { echo "openssl is missing (apt-get install openssl)" >&2; exit 2; }
umask 077
mkdir -p "$root/public" "$root/private" "$root/enclaves"
root=$(cd "$root" && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

say() { printf '%-5s %s\n' "$1" "${2#"$root"/}"; }

# An EC P-256 key (as SROS2), PKCS#8 PEM.
make_key() {
  if [ -s "$1" ]; then say kept "$1"; return; fi
  openssl genpkey -algorithm EC -pkeyopt ec_paramgen_curve:P-256 -out "$1" 2>/dev/null
  say made "$1"
}

# An openssl request configuration: subject CN=<name>, the extension lines <ext> (section ext).
request_config() {
  printf '[req]\nprompt = no\ndistinguished_name = dn\nx509_extensions = ext\n[dn]\nCN = %s\n[ext]\n%s\n' "$1" "$2"
}

# A self-signed CA certificate: make_ca <key> <cert> <common name>
make_ca() {
  make_key "$1"
  if [ -s "$2" ]; then say kept "$2"; return; fi
  request_config "$3" "basicConstraints = critical, CA:true
keyUsage = critical, keyCertSign, cRLSign, digitalSignature
subjectKeyIdentifier = hash" > "$tmp/ca.cnf"
  openssl req -x509 -new -key "$1" -config "$tmp/ca.cnf" -days "$days" -sha256 -out "$2"
  say made "$2"
}

# An identity certificate CN=<enclave> signed by a CA: make_identity <dir> <enclave> <ca key> <ca cert>
make_identity() {
  local dir=$1 enclave=$2 ca_key=$3 ca_cert=$4
  make_key "$dir/key.pem"
  if [ -s "$dir/cert.pem" ]; then say kept "$dir/cert.pem"; return; fi
  request_config "$enclave" "basicConstraints = critical, CA:false
keyUsage = critical, digitalSignature, keyAgreement" > "$tmp/id.cnf"
  openssl req -new -key "$dir/key.pem" -config "$tmp/id.cnf" -out "$tmp/id.csr"
  openssl x509 -req -in "$tmp/id.csr" -CA "$ca_cert" -CAkey "$ca_key" -set_serial "0x$(openssl rand -hex 8)" \
    -days "$days" -sha256 -extfile "$tmp/id.cnf" -extensions ext -out "$dir/cert.pem" 2>/dev/null
  say made "$dir/cert.pem"
}

# Writes <xml> from stdin when it differs, and (re)signs <p7s> when the XML changed or it is missing:
# write_signed <xml> <p7s> <ca key> <ca cert>
write_signed() {
  local xml=$1 p7s=$2 ca_key=$3 ca_cert=$4
  cat > "$tmp/new.xml"
  if [ -s "$xml" ] && cmp -s "$tmp/new.xml" "$xml" && [ -s "$p7s" ]; then
    say kept "$xml"; say kept "$p7s"; return
  fi
  cp "$tmp/new.xml" "$xml"
  openssl smime -sign -text -md sha256 -in "$xml" -out "$p7s" -signer "$ca_cert" -inkey "$ca_key"
  say made "$xml"; say made "$p7s"
}

# A relative symbolic link, as SROS2 makes them: link <target relative to the link's folder> <link>
link() {
  if [ -L "$2" ] && [ "$(readlink "$2")" = "$1" ]; then say kept "$2"; return; fi
  ln -sfn "$1" "$2"
  say made "$2"
}

# ---- CAs ------------------------------------------------------------------------------------
make_ca "$root/private/ca.key.pem" "$root/public/ca.cert.pem" "mlmap test CA"
for role in identity_ca permissions_ca; do
  link ca.cert.pem "$root/public/$role.cert.pem"
  link ca.key.pem "$root/private/$role.key.pem"
done
make_ca "$root/private/stranger_ca.key.pem" "$root/public/stranger_ca.cert.pem" "stranger CA (not trusted)"

# ---- Governance -----------------------------------------------------------------------------
write_signed "$root/enclaves/governance.xml" "$root/enclaves/governance.p7s" \
  "$root/private/ca.key.pem" "$root/public/ca.cert.pem" <<EOF
<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_governance.xsd">
  <domain_access_rules>
    <domain_rule>
      <domains>
        <id_range>
          <min>0</min>
          <max>232</max>
        </id_range>
      </domains>
      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
      <enable_join_access_control>true</enable_join_access_control>
      <discovery_protection_kind>ENCRYPT</discovery_protection_kind>
      <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>
      <rtps_protection_kind>$message</rtps_protection_kind>
      <topic_access_rules>
$topic_rules
      </topic_access_rules>
    </domain_rule>
  </domain_access_rules>
</dds>
EOF

# ---- Enclaves -------------------------------------------------------------------------------
# Topic lists: one <topic> per word. ROS 2 infrastructure every node uses (rmw's graph topic,
# rosout, serving its services: reading requests on rq/*, writing replies on rr/*) is allowed to
# everybody that is not a stranger. Calling a service is the opposite (writing its request,
# reading replies): the monitor may call any service, the read-only viewer only the services that
# read parameters, the node and the sensor none.
ros_pub="ros_discovery_info rt/rosout rr/*"
ros_sub="ros_discovery_info rq/*"
call_any_pub="rq/*"
call_any_sub="rr/*"
read_only_services="list_parameters get_parameters describe_parameters get_parameter_types"
call_read_only_pub="" call_read_only_sub=""
for service in $read_only_services; do
  call_read_only_pub+=" rq/*/${service}Request"
  call_read_only_sub+=" rr/*/${service}Reply"
done
topics() {
  local t
  for t in $1; do printf '            <topic>%s</topic>\n' "$t"; done
}
# rule <allow_rule|deny_rule> <publish topics> [<subscribe topics>]: for every domain 0..232
rule() {
  printf '      <%s>\n        <domains>\n          <id_range>\n' "$1"
  printf '            <min>0</min>\n            <max>232</max>\n          </id_range>\n        </domains>\n'
  printf '        <publish>\n          <topics>\n%s\n          </topics>\n        </publish>\n' "$(topics "$2")"
  if [ -n "${3:-}" ]; then
    printf '        <subscribe>\n          <topics>\n%s\n          </topics>\n        </subscribe>\n' "$(topics "$3")"
  fi
  printf '      </%s>\n' "$1"
}
# permissions <enclave> <cert> <publish topics> <subscribe topics> [<denied publish topics>]
# Valid as long as the enclave's certificate (so running the script again re-signs nothing).
permissions() {
  local enclave=$1 until
  until=$(date -u -d "$(openssl x509 -in "$2" -noout -enddate | cut -d= -f2)" +%Y-%m-%dT%H:%M:%S)
  cat <<EOF
<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_permissions.xsd">
  <permissions>
    <grant name="$enclave">
      <subject_name>CN=$enclave</subject_name>
      <validity>
        <not_before>2020-01-01T00:00:00</not_before>
        <not_after>$until</not_after>
      </validity>
EOF
  [ -z "${5:-}" ] || rule deny_rule "$5"   # first: the first rule that matches decides
  rule allow_rule "$3" "$4"
  printf '      <default>DENY</default>\n    </grant>\n  </permissions>\n</dds>\n'
}

# make_enclave <enclave> <ca key> <ca cert> <ca cert name in public/> <publish> <subscribe> [<deny>]
make_enclave() {
  local enclave=$1 ca_key=$2 ca_cert=$3 ca_name=$4
  local dir=$root/enclaves${enclave}
  mkdir -p "$dir"
  # ../ up to enclaves/, then ../public: as many levels as the enclave has tokens.
  local up="" rest=${enclave#/}
  while [ -n "$rest" ]; do up="../$up"; [ "${rest#*/}" = "$rest" ] && rest="" || rest=${rest#*/}; done
  make_identity "$dir" "$enclave" "$ca_key" "$ca_cert"
  link "${up}../public/$ca_name" "$dir/identity_ca.cert.pem"
  link "${up}../public/$ca_name" "$dir/permissions_ca.cert.pem"
  if [ "$ca_name" = ca.cert.pem ]; then
    link "${up}governance.p7s" "$dir/governance.p7s"
  else
    # The stranger's own governance, signed by its own CA (a complete identity elsewhere).
    write_signed "$dir/governance.xml" "$dir/governance.p7s" "$ca_key" "$ca_cert" < "$root/enclaves/governance.xml"
  fi
  permissions "$enclave" "$dir/cert.pem" "$5" "$6" "${7:-}" |
    write_signed "$dir/permissions.xml" "$dir/permissions.p7s" "$ca_key" "$ca_cert"
}

ca_key=$root/private/ca.key.pem ca_cert=$root/public/ca.cert.pem
make_enclave /mlmap/node "$ca_key" "$ca_cert" ca.cert.pem \
  "rt/*mlmap/* rt/*tf rt/*tf_static $ros_pub" \
  "rt/* $ros_sub"
make_enclave /mlmap/sensor "$ca_key" "$ca_cert" ca.cert.pem \
  "rt/*cloud rt/*pose rt/*odometry rt/*image* rt/*camera_info rt/*tf rt/*tf_static $ros_pub" \
  "$ros_sub"
make_enclave /ground/monitor "$ca_key" "$ca_cert" ca.cert.pem \
  "rt/* $ros_pub $call_any_pub" \
  "rt/* $ros_sub $call_any_sub"
make_enclave /ground/viewer_readonly "$ca_key" "$ca_cert" ca.cert.pem \
  "$ros_pub$call_read_only_pub" \
  "rt/*mlmap/* rt/*tf rt/*tf_static $ros_sub$call_read_only_sub" \
  "rt/*cloud rt/*pose rt/*odometry rt/*image* rt/*camera_info"
for vehicle in uav1 uav2; do
  make_enclave /fleet/$vehicle "$ca_key" "$ca_cert" ca.cert.pem \
    "rt/$vehicle/* rt/*tf rt/*tf_static $ros_pub" \
    "rt/* $ros_sub"
done
make_enclave /fleet/merger "$ca_key" "$ca_cert" ca.cert.pem \
  "rt/*mlmap/fleet/* $ros_pub" \
  "rt/*/mlmap/submaps $ros_sub"
make_enclave /stranger "$root/private/stranger_ca.key.pem" "$root/public/stranger_ca.cert.pem" \
  stranger_ca.cert.pem \
  "rt/* $ros_pub" \
  "rt/* $ros_sub"

# Every signature must verify against its CA (as Fast DDS will check them).
for p7s in "$root"/enclaves/governance.p7s "$root"/enclaves/*/permissions.p7s \
           "$root"/enclaves/*/*/permissions.p7s "$root"/enclaves/stranger/governance.p7s; do
  [ -e "$p7s" ] || continue
  ca=$ca_cert
  case $p7s in "$root"/enclaves/stranger/*) ca=$root/public/stranger_ca.cert.pem ;; esac
  openssl smime -verify -in "$p7s" -CAfile "$ca" -out /dev/null 2>/dev/null ||
    { echo "signature check failed: $p7s" >&2; exit 1; }
done
for cert in "$root"/enclaves/*/cert.pem "$root"/enclaves/*/*/cert.pem; do
  [ -e "$cert" ] || continue
  ca=$ca_cert
  case $cert in "$root"/enclaves/stranger/*) ca=$root/public/stranger_ca.cert.pem ;; esac
  openssl verify -CAfile "$ca" "$cert" >/dev/null || { echo "certificate check failed: $cert" >&2; exit 1; }
done
echo "keystore ready: $root (test keys: never commit them, never fly them)"
echo "use: ROS_SECURITY_KEYSTORE=$root ROS_SECURITY_ENABLE=true ROS_SECURITY_STRATEGY=Enforce ROS_SECURITY_ENCLAVE_OVERRIDE=/mlmap/node"
