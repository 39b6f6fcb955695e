#!/usr/bin/env bash
# Creates (or extends) a DDS-Security keystore for cpgmatch, in the layout ROS 2 users know from sros2:
#
#   KEYSTORE/public/ca.cert.pem                     the study CA (identity CA = permissions CA, as in sros2)
#   KEYSTORE/public/crl.pem                         its certificate revocation list (CRL), signed by the CA
#   KEYSTORE/private/ca.key.pem                     its key (0600; keep it off the cluster)
#   KEYSTORE/enclaves/governance.{xml,p7s}          domain and topic rules, signed by the CA
#   KEYSTORE/enclaves/<name>/identity_ca.cert.pem   \
#                            permissions_ca.cert.pem |  what a process started with
#                            governance.p7s          |  --keystore KEYSTORE --enclave <name> loads
#                            cert.pem key.pem        |  (PKI-DH authentication, access control,
#                            permissions.{xml,p7s}  /   AES-GCM encryption)
#                            crl.pem                    a copy of the CA's CRL (Fast DDS PKI-DH identity_crl;
#                                                       required: every run copies it into enclaves lacking it)
#
#   make-study-pki.sh KEYSTORE                       CA + the enclaves optimizer, worker, operator, viewer
#   make-study-pki.sh KEYSTORE NAME:ROLE ...         more enclaves, e.g. node12:worker
#   make-study-pki.sh KEYSTORE revoke [NAME ...]     revokes enclave NAME's certificate: a new CRL, copied into
#                                                    every enclave of KEYSTORE; copy it to every host (each
#                                                    participant reads it when it starts) and restart them.
#                                                    Without names: a fresh CRL (one expires with the CA, after
#                                                    --days + 1; an expired CRL would make Fast DDS refuse everyone)
#
# Every certificate's subject is CN=<enclave name>. With --keystore a simulation worker or robot agent
# takes that CN as its worker id (or CN/suffix), and the optimizer counts a report or announcement only
# from the certificate that owns its worker id (docs/deploy.md).
#   options: --days N (validity, default 365), --expired NAME:ROLE (a certificate that expired in 2020: tests)
#
# Roles: optimizer writes candidates, study state, trials and replies and reads reports, workers and
# commands; worker reads candidates and emergency stops and writes reports and announcements; operator
# submits and controls studies (and reads what it needs to follow them) and sends emergency stops; viewer
# reads state, trials and workers only (natively and on the ROS 2 view's rt/cpgmatch/* topics).
# Topic names are listed exactly, never as patterns: a '*' would have to match across '/'.
set -euo pipefail

usage() {
  echo "usage: make-study-pki.sh KEYSTORE [--days N] [--expired NAME:ROLE] [NAME:ROLE ...]" >&2
  echo "       make-study-pki.sh KEYSTORE revoke [NAME ...]" >&2
  exit 2
}
[[ $# -ge 1 ]] || usage
KEYSTORE=$1; shift
DAYS=365
if [[ ${1:-} == revoke ]]; then
  shift  # no names: a fresh CRL (its next-update date moves on) with the revocations so far
  command -v openssl >/dev/null || { echo "make-study-pki.sh: openssl is not installed" >&2; exit 1; }
  CA_CNF=$KEYSTORE/private/ca.cnf
  [[ -f $CA_CNF && -f $KEYSTORE/private/ca.key.pem ]] || { echo "revoke: $KEYSTORE has no study CA (private/ca.cnf)" >&2; exit 2; }
  # Keystores made before revocation existed lack the CRL settings.
  grep -q '^crlnumber' "$CA_CNF" || sed -i 's|^serial = .*|&\ncrlnumber = $dir/crlnumber\ndefault_crl_days = 365|' "$CA_CNF"
  [[ -f $KEYSTORE/private/crlnumber ]] || echo 1000 >"$KEYSTORE/private/crlnumber"
  for name in "$@"; do
    cert=$KEYSTORE/enclaves/$name/cert.pem
    [[ -f $cert ]] || { echo "revoke: no enclave '$name' ($cert is missing)" >&2; exit 2; }
    openssl ca -config "$CA_CNF" -revoke "$cert" -crl_reason keyCompromise 2>"$KEYSTORE/private/ca.log" ||
      { grep -q "already revoked" "$KEYSTORE/private/ca.log" || { cat "$KEYSTORE/private/ca.log" >&2; exit 1; }; }
    echo "revoked enclave $name (serial $(openssl x509 -in "$cert" -noout -serial | cut -d= -f2))"
  done
  openssl ca -config "$CA_CNF" -gencrl -out "$KEYSTORE/public/crl.pem" 2>"$KEYSTORE/private/ca.log" ||
    { cat "$KEYSTORE/private/ca.log" >&2; exit 1; }
  for dir in "$KEYSTORE"/enclaves/*/; do [[ -f $dir/cert.pem ]] && cp "$KEYSTORE/public/crl.pem" "$dir/crl.pem"; done
  echo "new CRL: $KEYSTORE/public/crl.pem, copied into every enclave; copy it to every host and restart its processes"
  exit 0
fi
ENCLAVES=()
EXPIRED=()
while [[ $# -gt 0 ]]; do
  case $1 in
    --days) [[ ${2:-} =~ ^[0-9]+$ && $2 -ge 1 ]] || { echo "--days: a positive number of days" >&2; exit 2; }; DAYS=$2; shift 2 ;;
    --expired) [[ -n ${2:-} ]] || usage; EXPIRED+=("$2"); shift 2 ;;
    -*) usage ;;
    *) ENCLAVES+=("$1"); shift ;;
  esac
done
[[ ${#ENCLAVES[@]} -gt 0 || ${#EXPIRED[@]} -gt 0 ]] || ENCLAVES=(optimizer:optimizer worker:worker operator:operator viewer:viewer)
command -v openssl >/dev/null || { echo "make-study-pki.sh: openssl is not installed" >&2; exit 1; }

C=cpgmatch/candidates R=cpgmatch/reports W=cpgmatch/workers S=cpgmatch/study_state
T=cpgmatch/trials K=cpgmatch/commands Y=cpgmatch/replies E=cpgmatch/estop P=cpgmatch/study_specs
X=cpgmatch/rollout_traces
# Emergency stops: the operator sends them (cpgmatch estop), workers read them (robot agents act on
# them; simulation workers have no reader). A viewer may not stop a robot.
# Study specs: the optimizer publishes them, workers run them, and anyone who may read a study may read
# what it computes. Rollout traces: robot agents send them, the optimizer stores them.
# The ROS 2 view (docs/ros2.md): the optimizer republishes state, trials and workers under ROS 2's names;
# whoever may read those natively may read them there.
RS=rt/cpgmatch/study_state RT=rt/cpgmatch/trials RW=rt/cpgmatch/workers
ROS2="$RS $RT $RW"
declare -A PUBLISH=([optimizer]="$C $S $T $Y $P $ROS2" [worker]="$R $W $X" [operator]="$K $E" [viewer]="")
declare -A SUBSCRIBE=([optimizer]="$R $W $K $X" [worker]="$C $E $P" [operator]="$Y $S $T $W $P $ROS2" [viewer]="$S $T $W $P $ROS2")
ALL_TOPICS="$C $R $W $S $T $K $Y $E $P $X $ROS2"

mkdir -p "$KEYSTORE"/{public,private,enclaves}
chmod 700 "$KEYSTORE/private"
CA_CERT=$KEYSTORE/public/ca.cert.pem
CA_KEY=$KEYSTORE/private/ca.key.pem
CA_CNF=$KEYSTORE/private/ca.cnf

# ---- the study CA (created once; later runs add enclaves signed by the same CA) ----------------------
if [[ ! -f $CA_CERT ]]; then
  openssl ecparam -name prime256v1 -genkey -noout -out "$CA_KEY" 2>/dev/null
  chmod 600 "$CA_KEY"
  openssl req -x509 -new -key "$CA_KEY" -sha256 -days "$((DAYS + 1))" -subj "/O=cpgmatch/CN=cpgmatch study CA" \
    -addext "basicConstraints=critical,CA:TRUE" -addext "keyUsage=critical,digitalSignature,keyCertSign,cRLSign" -out "$CA_CERT"
  : >"$KEYSTORE/private/index.txt"
  echo 1000 >"$KEYSTORE/private/serial"
  cat >"$CA_CNF" <<CNF
[ ca ]
default_ca = study_ca
[ study_ca ]
dir = $KEYSTORE/private
database = \$dir/index.txt
serial = \$dir/serial
crlnumber = \$dir/crlnumber
default_crl_days = $((DAYS + 1))
new_certs_dir = \$dir
certificate = $CA_CERT
private_key = $CA_KEY
default_md = sha256
policy = any_name
unique_subject = no
copy_extensions = none
x509_extensions = participant
[ any_name ]
commonName = supplied
[ participant ]
basicConstraints = critical,CA:FALSE
keyUsage = critical,digitalSignature,keyAgreement
CNF
  ln -sf ca.cert.pem "$KEYSTORE/public/identity_ca.cert.pem"
  ln -sf ca.cert.pem "$KEYSTORE/public/permissions_ca.cert.pem"
fi
# The CRL (empty until something is revoked): every participant checks its peers' certificates against it.
if [[ ! -f $KEYSTORE/public/crl.pem ]]; then
  grep -q '^crlnumber' "$CA_CNF" || sed -i 's|^serial = .*|&\ncrlnumber = $dir/crlnumber\ndefault_crl_days = 365|' "$CA_CNF"
  [[ -f $KEYSTORE/private/crlnumber ]] || echo 1000 >"$KEYSTORE/private/crlnumber"
  openssl ca -config "$CA_CNF" -gencrl -out "$KEYSTORE/public/crl.pem" 2>"$KEYSTORE/private/ca.log" ||
    { cat "$KEYSTORE/private/ca.log" >&2; exit 1; }
fi
# Every enclave needs it: cpgmatch refuses an enclave without crl.pem (revocation must not be off by
# accident). Enclaves made before revocation existed get the current CRL here, when the keystore is extended.
for dir in "$KEYSTORE"/enclaves/*/; do
  if [[ -f $dir/cert.pem && ! -e $dir/crl.pem ]]; then cp "$KEYSTORE/public/crl.pem" "$dir/crl.pem"; fi
done

# The CA signs governance and permissions itself (S/MIME), hence digitalSignature in its key usage.
sign() { openssl smime -sign -text -in "$1" -out "$2" -signer "$CA_CERT" -inkey "$CA_KEY"; }

# ---- governance: who may join, what is protected -----------------------------------------------------
if [[ ! -f $KEYSTORE/enclaves/governance.p7s ]]; then
  {
    cat <<XML
<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-Security/20170801/omg_shared_ca_governance.xsd">
  <domain_access_rules>
    <domain_rule>
      <domains><id_range><min>0</min><max>232</max></id_range></domains>
      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
      <enable_join_access_control>true</enable_join_access_control>
      <discovery_protection_kind>ENCRYPT</discovery_protection_kind>
      <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>
      <rtps_protection_kind>SIGN</rtps_protection_kind>
      <topic_access_rules>
XML
    for topic in $ALL_TOPICS '*'; do
      cat <<XML
        <topic_rule>
          <topic_expression>$topic</topic_expression>
          <enable_discovery_protection>true</enable_discovery_protection>
          <enable_liveliness_protection>true</enable_liveliness_protection>
          <enable_read_access_control>true</enable_read_access_control>
          <enable_write_access_control>true</enable_write_access_control>
          <metadata_protection_kind>ENCRYPT</metadata_protection_kind>
          <data_protection_kind>ENCRYPT</data_protection_kind>
        </topic_rule>
XML
    done
    cat <<XML
      </topic_access_rules>
    </domain_rule>
  </domain_access_rules>
</dds>
XML
  } >"$KEYSTORE/enclaves/governance.xml"
  sign "$KEYSTORE/enclaves/governance.xml" "$KEYSTORE/enclaves/governance.p7s"
fi

topics_xml() { local t; for t in $1; do printf '            <topic>%s</topic>\n' "$t"; done; }

# make_enclave NAME ROLE STARTDATE ENDDATE (dates as YYYYMMDDHHMMSSZ)
make_enclave() {
  local name=$1 role=$2 start=$3 end=$4
  [[ $name =~ ^[A-Za-z0-9._-]{1,63}$ ]] || { echo "enclave name '$name': 1-63 of A-Z a-z 0-9 . _ -" >&2; exit 2; }
  [[ -n ${PUBLISH[$role]+x} ]] || { echo "enclave $name: role '$role' is not one of optimizer, worker, operator, viewer" >&2; exit 2; }
  local dir=$KEYSTORE/enclaves/$name
  mkdir -p "$dir"
  openssl ecparam -name prime256v1 -genkey -noout -out "$dir/key.pem" 2>/dev/null
  chmod 600 "$dir/key.pem"
  openssl req -new -key "$dir/key.pem" -subj "/CN=$name" -out "$dir/req.pem"
  openssl ca -batch -config "$CA_CNF" -startdate "$start" -enddate "$end" -in "$dir/req.pem" -out "$dir/cert.pem" \
    -notext 2>"$dir/ca.log" || { cat "$dir/ca.log" >&2; exit 1; }
  rm -f "$dir/req.pem" "$dir/ca.log"
  cp "$CA_CERT" "$dir/identity_ca.cert.pem"
  cp "$CA_CERT" "$dir/permissions_ca.cert.pem"
  cp "$KEYSTORE/enclaves/governance.p7s" "$dir/governance.p7s"
  cp "$KEYSTORE/public/crl.pem" "$dir/crl.pem"
  local iso_start iso_end
  iso_start=$(date -u -d "${start:0:8} ${start:8:2}:${start:10:2}:${start:12:2}" +%Y-%m-%dT%H:%M:%S)
  iso_end=$(date -u -d "${end:0:8} ${end:8:2}:${end:10:2}:${end:12:2}" +%Y-%m-%dT%H:%M:%S)
  cat >"$dir/permissions.xml" <<XML
<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-Security/20170801/omg_shared_ca_permissions.xsd">
  <permissions>
    <grant name="$name">
      <subject_name>CN=$name</subject_name>
      <validity><not_before>$iso_start</not_before><not_after>$iso_end</not_after></validity>
      <allow_rule>
        <domains><id_range><min>0</min><max>232</max></id_range></domains>
XML
  if [[ -n ${PUBLISH[$role]} ]]; then
    { echo "        <publish><topics>"; topics_xml "${PUBLISH[$role]}"; echo "        </topics></publish>"; } >>"$dir/permissions.xml"
  fi
  if [[ -n ${SUBSCRIBE[$role]} ]]; then
    { echo "        <subscribe><topics>"; topics_xml "${SUBSCRIBE[$role]}"; echo "        </topics></subscribe>"; } >>"$dir/permissions.xml"
  fi
  cat >>"$dir/permissions.xml" <<XML
      </allow_rule>
      <default>DENY</default>
    </grant>
  </permissions>
</dds>
XML
  sign "$dir/permissions.xml" "$dir/permissions.p7s"
  echo "enclave $name ($role): $dir, valid $iso_start .. $iso_end UTC"
}

now=$(date -u -d "-1 hour" +%Y%m%d%H%M%SZ)  # an hour of slack for clocks that lag
until=$(date -u -d "+$DAYS days" +%Y%m%d%H%M%SZ)
for e in "${ENCLAVES[@]}"; do make_enclave "${e%%:*}" "${e#*:}" "$now" "$until"; done
for e in "${EXPIRED[@]}"; do make_enclave "${e%%:*}" "${e#*:}" 20200101000000Z 20200102000000Z; done
